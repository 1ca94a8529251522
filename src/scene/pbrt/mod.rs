//! pbrt scene files (pbrt-v4, and pbrt-v3 where it differs) read into a
//! [`Scene`]: our own tokenizer ([`lexer`]) so that every error names the
//! file, line and column; the directives and graphics state here; shapes and
//! lights in [`shapes`]; materials in [`material`]. What is approximated or
//! ignored becomes one note each, with its file and line (`docs/pbrt.md`).

mod camera;
mod images;
mod lexer;
mod lights;
mod material;
mod mix;
mod params;
mod shapes;
mod texture;

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::rc::Rc;

use glam::{DMat4, DVec3, Vec3};

use self::lexer::{Kind, Loc, Token};
use self::material::{Mapped, Texture};
use self::params::Params;
use super::{Camera, GuidingSettings, RenderSettings, Scene, SceneError};

/// Notes on what the import approximates or ignores, each `file:line: what`.
pub(crate) struct Notes {
    /// `--strict`: an approximation is refused instead.
    strict: bool,
    list: Vec<String>,
}

impl Notes {
    /// Something in the scene rendered differently from pbrt (or not at all):
    /// noted, or refused with `--strict`.
    pub fn approximated(&mut self, loc: &Loc, message: String) -> Result<(), SceneError> {
        if self.strict {
            return Err(loc.error(format!("{message} (refused by --strict)")));
        }
        self.setting(loc, message);
        Ok(())
    }

    /// A render setting rlpt takes from its own options (sampler, filter, ...):
    /// noted, also with `--strict`, since the picture does not change.
    pub fn setting(&mut self, loc: &Loc, message: String) {
        let note = format!("{}: {message}", loc.at());
        if !self.list.contains(&note) {
            self.list.push(note);
        }
    }
}

/// Graphics state: what `AttributeBegin`/`End` save and restore.
#[derive(Clone, Debug)]
struct State {
    ctm: DMat4,
    reverse: bool,
    /// Index into `Importer::materials`.
    material: usize,
    area: Option<AreaLight>,
    /// `ActiveTransform EndTime`: transforms apply to the end of a motion,
    /// which rlpt does not render.
    end_time_only: bool,
}

#[derive(Clone, Debug, PartialEq)]
struct AreaLight {
    radiance: Vec3,
    two_sided: bool,
}

/// A shape inside `ObjectBegin`/`ObjectEnd`, placed at each `ObjectInstance`.
#[derive(Clone, Debug)]
struct Pending {
    kind: String,
    params: Params,
    loc: Loc,
    state: State,
}

/// How the stack was pushed: `AttributeBegin` (whole state), `TransformBegin`
/// (the transform only) or `ObjectBegin`.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Push {
    Attribute,
    Transform,
    Object,
}

struct Importer {
    /// Relative paths start here: the directory of the file given (as pbrt's).
    base: PathBuf,
    notes: Notes,
    state: State,
    stack: Vec<(State, Push, Loc)>,
    coordinate_systems: HashMap<String, DMat4>,
    textures: HashMap<String, Texture>,
    materials: Vec<Mapped>,
    named_materials: HashMap<String, usize>,
    /// `Camera`: camera-from-world, fov, where.
    camera: Option<(DMat4, f64, Loc)>,
    /// World to the space rlpt renders in, fixed at `WorldBegin`: pbrt's camera
    /// space mirrored in x (see [`Importer::world_begin`]).
    bake: DMat4,
    in_world: bool,
    render: RenderSettings,
    objects: HashMap<String, Vec<Pending>>,
    object: Option<(String, Vec<Pending>)>,
    out: shapes::Output,
    include_depth: usize,
}

/// Reads the pbrt file at `path`; `strict` refuses what would be noted as approximated.
pub(super) fn load(path: &Path, strict: bool) -> Result<Scene, SceneError> {
    let base = path.parent().unwrap_or(Path::new("")).to_path_buf();
    let default = Mapped {
        material: super::Material::plain("pbrt default diffuse", super::MaterialKind::Diffuse, Vec3::splat(0.5)),
        mapping:
            "pbrt default diffuse: diffuse -> diffuse (reflectance [0.5, 0.5, 0.5], used where no Material was given)"
                .into(),
    };
    let mut im = Importer {
        base,
        notes: Notes { strict, list: Vec::new() },
        state: State { ctm: DMat4::IDENTITY, reverse: false, material: 0, area: None, end_time_only: false },
        stack: Vec::new(),
        coordinate_systems: HashMap::new(),
        textures: HashMap::new(),
        materials: vec![default],
        named_materials: HashMap::new(),
        camera: None,
        bake: DMat4::IDENTITY,
        in_world: false,
        render: RenderSettings { width: 1280, height: 720, spp: 16, max_bounces: 5, russian_roulette_depth: None },
        objects: HashMap::new(),
        object: None,
        out: shapes::Output::default(),
        include_depth: 0,
    };
    im.file(path, path.display().to_string(), None)?;
    im.finish(path)
}

fn word(t: &Token) -> Option<&str> {
    match &t.kind {
        Kind::Word(w) => Some(w),
        _ => None,
    }
}

impl Importer {
    /// Tokenizes and runs one file (the scene, or an `Include`d one named at `from`).
    fn file(&mut self, path: &Path, shown: String, from: Option<&Loc>) -> Result<(), SceneError> {
        let text = std::fs::read_to_string(path).map_err(|e| match from {
            None => SceneError::Io { path: path.to_path_buf(), error: e },
            Some(loc) => {
                loc.error(format!("cannot read the included file {shown} (resolved to {}): {e}", path.display()))
            }
        })?;
        let name: Rc<str> = Rc::from(path.display().to_string());
        let tokens = lexer::tokenize(&text, &name)?;
        let mut i = 0;
        while i < tokens.len() {
            self.directive(&tokens, &mut i)?;
        }
        Ok(())
    }

    /// Reads `n` numbers, bracketed or not.
    fn numbers(tokens: &[Token], i: &mut usize, n: usize, what: &Token) -> Result<Vec<f64>, SceneError> {
        let bracketed = tokens.get(*i).is_some_and(|t| t.kind == Kind::Open);
        if bracketed {
            *i += 1;
        }
        let mut out = Vec::with_capacity(n);
        for k in 0..n {
            match tokens.get(*i) {
                Some(Token { kind: Kind::Num(x), .. }) => out.push(*x),
                Some(t) => {
                    return Err(t.loc.error(format!(
                        "{} takes {n} numbers; expected number {} of them, found {}",
                        word(what).unwrap_or(""),
                        k + 1,
                        t.describe()
                    )))
                }
                None => {
                    return Err(what.loc.error(format!(
                        "{} takes {n} numbers; found the end of the file after {k}",
                        word(what).unwrap_or("")
                    )))
                }
            }
            *i += 1;
        }
        if bracketed {
            match tokens.get(*i) {
                Some(t) if t.kind == Kind::Close => *i += 1,
                Some(t) => return Err(t.loc.error(format!("expected `]` after {n} numbers, found {}", t.describe()))),
                None => {
                    return Err(what.loc.error(format!("expected `]` after {n} numbers, found the end of the file")))
                }
            }
        }
        Ok(out)
    }

    /// Reads one quoted string argument.
    fn string(tokens: &[Token], i: &mut usize, what: &Token, meaning: &str) -> Result<String, SceneError> {
        match tokens.get(*i) {
            Some(Token { kind: Kind::Str(s), .. }) => {
                *i += 1;
                Ok(s.clone())
            }
            Some(t) => Err(t.loc.error(format!(
                "{} takes {meaning} in quotes; found {}",
                word(what).unwrap_or(""),
                t.describe()
            ))),
            None => Err(what
                .loc
                .error(format!("{} takes {meaning} in quotes; found the end of the file", word(what).unwrap_or("")))),
        }
    }

    fn directive(&mut self, tokens: &[Token], i: &mut usize) -> Result<(), SceneError> {
        let t = &tokens[*i];
        let Some(name) = word(t) else {
            return Err(t
                .loc
                .error(format!("expected a directive (such as Shape or WorldBegin), found {}", t.describe())));
        };
        let loc = t.loc.clone();
        let here = loc.clone();
        let ctm_before = self.state.ctm;
        *i += 1;
        let world_only = |im: &Self| -> Result<(), SceneError> {
            if im.in_world {
                Ok(())
            } else {
                Err(loc.error(format!("{name} is allowed only after WorldBegin")))
            }
        };
        match name {
            "Identity" => self.state.ctm = DMat4::IDENTITY,
            "Translate" => {
                let v = Self::numbers(tokens, i, 3, t)?;
                self.state.ctm *= DMat4::from_translation(DVec3::new(v[0], v[1], v[2]));
            }
            "Scale" => {
                let v = Self::numbers(tokens, i, 3, t)?;
                self.state.ctm *= DMat4::from_scale(DVec3::new(v[0], v[1], v[2]));
            }
            "Rotate" => {
                let v = Self::numbers(tokens, i, 4, t)?;
                let axis = DVec3::new(v[1], v[2], v[3]);
                if axis.length() == 0.0 {
                    return Err(loc.error("Rotate needs a non-zero axis, found [0, 0, 0]"));
                }
                self.state.ctm *= DMat4::from_axis_angle(axis.normalize(), v[0].to_radians());
            }
            "LookAt" => {
                let v = Self::numbers(tokens, i, 9, t)?;
                self.state.ctm *= camera::look_at(&v).ok_or_else(|| {
                    loc.error(
                        "LookAt: the eye and the point looked at coincide, or `up` is parallel to the view direction",
                    )
                })?;
            }
            "Transform" | "ConcatTransform" => {
                let v = Self::numbers(tokens, i, 16, t)?;
                let m = DMat4::from_cols_slice(&v);
                if m.determinant() == 0.0 || !m.determinant().is_finite() {
                    return Err(loc.error(format!("{name}: the matrix is singular (determinant 0)")));
                }
                self.state.ctm = if name == "Transform" { m } else { self.state.ctm * m };
            }
            "CoordinateSystem" => {
                let n = Self::string(tokens, i, t, "a name")?;
                self.coordinate_systems.insert(n, self.state.ctm);
            }
            "CoordSysTransform" => {
                let n = Self::string(tokens, i, t, "a name")?;
                match self.coordinate_systems.get(&n) {
                    Some(m) => self.state.ctm = *m,
                    None => {
                        return Err(loc.error(format!(
                            "CoordSysTransform: no coordinate system named \"{n}\" (named so far: {})",
                            self.coordinate_systems.keys().cloned().collect::<Vec<_>>().join(", ")
                        )))
                    }
                }
            }
            "ReverseOrientation" => self.state.reverse = !self.state.reverse,
            "TransformTimes" => {
                Self::numbers(tokens, i, 2, t)?;
                self.notes.setting(&loc, "TransformTimes ignored (rlpt has no motion blur)".into());
            }
            "ActiveTransform" => {
                let which = tokens.get(*i).and_then(word).map(str::to_string);
                *i += 1;
                self.state.end_time_only = match which.as_deref() {
                    Some("All") | Some("StartTime") => false,
                    Some("EndTime") => true,
                    _ => return Err(loc.error("ActiveTransform takes All, StartTime or EndTime")),
                };
            }
            "AttributeBegin" | "TransformBegin" => {
                let push = if name == "AttributeBegin" { Push::Attribute } else { Push::Transform };
                self.stack.push((self.state.clone(), push, loc));
            }
            "AttributeEnd" | "TransformEnd" => {
                let want = if name == "AttributeEnd" { Push::Attribute } else { Push::Transform };
                match self.stack.pop() {
                    Some((saved, push, _)) if push == want => {
                        if push == Push::Attribute {
                            self.state = saved;
                        } else {
                            self.state.ctm = saved.ctm;
                        }
                    }
                    Some((_, push, opened)) => {
                        return Err(loc.error(format!("{name} closes the {push:?}Begin of line {}", opened.line)))
                    }
                    None => return Err(loc.error(format!("{name} without a matching Begin"))),
                }
            }
            "Attribute" => {
                Self::string(tokens, i, t, "a target (shape, light, material, medium or texture)")?;
                let p = params::parse(tokens, i)?;
                for q in &p.list {
                    self.notes.approximated(&q.loc, format!("Attribute parameter {} ignored", q.label()))?;
                }
            }
            "Option" | "ColorSpace" => {
                if name == "ColorSpace" {
                    Self::string(tokens, i, t, "a colour space")?;
                }
                let p = params::parse(tokens, i)?;
                let what = p.list.iter().map(|q| q.label()).collect::<Vec<_>>().join(", ");
                self.notes.setting(&loc, format!("{name} {what} ignored"));
            }
            "Camera" | "Sampler" | "Film" | "PixelFilter" | "Integrator" | "Accelerator" | "SurfaceIntegrator"
            | "VolumeIntegrator" | "Renderer" => {
                if self.in_world {
                    return Err(loc.error(format!("{name} must come before WorldBegin")));
                }
                let ty = Self::string(tokens, i, t, "a type")?;
                let p = params::parse(tokens, i)?;
                self.option(name, &ty, &p, &loc)?;
            }
            "WorldBegin" => self.world_begin(&loc)?,
            "WorldEnd" => {}
            "Include" | "Import" => {
                let f = Self::string(tokens, i, t, "a file name")?;
                if self.include_depth > 32 {
                    return Err(loc.error(format!("{name} \"{f}\": includes nested more than 32 deep (a cycle?)")));
                }
                let path = self.base.join(&f);
                self.include_depth += 1;
                self.file(&path, f, Some(&loc))?;
                self.include_depth -= 1;
            }
            "Texture" => {
                world_only(self)?;
                let tex = Self::string(tokens, i, t, "a texture name")?;
                let ty = Self::string(tokens, i, t, "a texture type (spectrum or float)")?;
                let class = Self::string(tokens, i, t, "a texture class")?;
                let p = params::parse(tokens, i)?;
                let texture = self.texture(&ty, &class, &p, &loc)?;
                self.textures.insert(tex, texture);
            }
            "Material" | "MakeNamedMaterial" => {
                world_only(self)?;
                let first = Self::string(tokens, i, t, if name == "Material" { "a material type" } else { "a name" })?;
                let p = params::parse(tokens, i)?;
                let (ty, label) = if name == "Material" {
                    (first.clone(), format!("{first} (line {})", loc.line))
                } else {
                    let ty = p.string("type")?.ok_or_else(|| {
                        loc.error(format!("MakeNamedMaterial \"{first}\": missing parameter \"string type\""))
                    })?;
                    (ty, first.clone())
                };
                let index = self.material(&ty, &p, &loc, &label)?;
                if name == "Material" {
                    self.state.material = index;
                } else {
                    self.named_materials.insert(first, index);
                }
            }
            "NamedMaterial" => {
                world_only(self)?;
                let n = Self::string(tokens, i, t, "a material name")?;
                self.state.material = *self.named_materials.get(&n).ok_or_else(|| {
                    loc.error(format!("NamedMaterial \"{n}\": no material of that name was made (MakeNamedMaterial)"))
                })?;
            }
            "AreaLightSource" => {
                world_only(self)?;
                let ty = Self::string(tokens, i, t, "a type")?;
                let p = params::parse(tokens, i)?;
                self.area_light(&ty, &p, &loc)?;
            }
            "LightSource" => {
                world_only(self)?;
                let ty = Self::string(tokens, i, t, "a type")?;
                let p = params::parse(tokens, i)?;
                self.light(&ty, &p, &loc)?;
            }
            "Shape" => {
                world_only(self)?;
                let kind = Self::string(tokens, i, t, "a shape type")?;
                let params = params::parse(tokens, i)?;
                let pending = Pending { kind, params, loc, state: self.state.clone() };
                match &mut self.object {
                    Some((_, shapes)) => shapes.push(pending),
                    None => self.shape(&pending, &DMat4::IDENTITY, false)?,
                }
            }
            "ObjectBegin" => {
                world_only(self)?;
                let n = Self::string(tokens, i, t, "an object name")?;
                if self.object.is_some() {
                    return Err(loc.error("ObjectBegin inside another ObjectBegin"));
                }
                self.stack.push((self.state.clone(), Push::Object, loc));
                self.object = Some((n, Vec::new()));
            }
            "ObjectEnd" => {
                let Some((n, shapes)) = self.object.take() else {
                    return Err(loc.error("ObjectEnd without ObjectBegin"));
                };
                match self.stack.pop() {
                    Some((saved, Push::Object, _)) => self.state = saved,
                    _ => return Err(loc.error("ObjectEnd closes an AttributeBegin or TransformBegin")),
                }
                self.objects.insert(n, shapes);
            }
            "ObjectInstance" => {
                world_only(self)?;
                let n = Self::string(tokens, i, t, "an object name")?;
                let shapes = self.objects.get(&n).cloned().ok_or_else(|| {
                    loc.error(format!("ObjectInstance \"{n}\": no object of that name (ObjectBegin)"))
                })?;
                for s in &shapes {
                    self.shape(s, &self.state.ctm.clone(), true)?;
                }
            }
            "MakeNamedMedium" | "MediumInterface" => {
                let skip = if name == "MakeNamedMedium" { 1 } else { 2 };
                for _ in 0..skip {
                    if matches!(tokens.get(*i).map(|t| &t.kind), Some(Kind::Str(_))) {
                        *i += 1;
                    }
                }
                params::parse(tokens, i)?;
                self.notes.approximated(&loc, format!("{name} ignored (rlpt has no participating media)"))?;
            }
            _ => {
                return Err(loc.error(format!(
                    "unknown directive `{name}`; expected a pbrt directive such as Shape, Material, LightSource, \
                     AttributeBegin or WorldBegin"
                )))
            }
        }
        const TRANSFORMS: &[&str] = &[
            "Identity",
            "Translate",
            "Scale",
            "Rotate",
            "LookAt",
            "Transform",
            "ConcatTransform",
            "CoordSysTransform",
        ];
        if self.state.end_time_only && TRANSFORMS.contains(&name) {
            self.state.ctm = ctm_before;
            let message = format!("{name} under ActiveTransform EndTime ignored (rlpt has no motion blur)");
            self.notes.approximated(&here, message)?;
        }
        Ok(())
    }

    fn finish(mut self, path: &Path) -> Result<Scene, SceneError> {
        if let Some((_, push, opened)) = self.stack.last() {
            self.notes.setting(opened, format!("{push:?}Begin is never closed"));
        }
        if !self.in_world {
            return Err(SceneError::Invalid {
                file: path.display().to_string(),
                position: None,
                message: "no WorldBegin: the file describes no world to render".into(),
            });
        }
        let (_, fov, _) = self.camera.clone().expect("set at WorldBegin");
        let (w, h) = (self.render.width as f64, self.render.height as f64);
        // pbrt's fov spans the shorter image side; rlpt's is vertical.
        let vfov = if w >= h { fov } else { 2.0 * ((fov.to_radians() / 2.0).tan() * h / w).atan().to_degrees() };
        let camera = Camera { position: Vec3::ZERO, forward: Vec3::Z, up: Vec3::Y, vfov_deg: vfov as f32, near: 0.0 };
        let shapes::Output { materials, spheres, meshes, mut environment, mut environment_map, delta_lights, .. } =
            self.out;
        // A uniform `infinite` light beside an image one: added to its texels.
        if let Some(map) = environment_map.as_mut() {
            for t in &mut map.texels {
                *t = [t[0] + environment.x, t[1] + environment.y, t[2] + environment.z];
            }
            environment = Vec3::ZERO;
        }
        if spheres.is_empty() && meshes.is_empty() {
            return Err(SceneError::Invalid {
                file: path.display().to_string(),
                position: None,
                message: "the scene has no shape rlpt renders (plymesh, trianglemesh, bilinearmesh, sphere)".into(),
            });
        }
        let mappings = self.materials.iter().map(|m| m.mapping.clone()).collect();
        let mut scene = Scene {
            source: path.to_path_buf(),
            camera,
            render: self.render,
            environment,
            environment_map,
            materials,
            spheres,
            quads: Vec::new(),
            meshes,
            notes: self.notes.list,
            material_mappings: mappings,
            guiding: GuidingSettings::default(),
            textures: Vec::new(),
            delta_lights,
        };
        crate::scene::texture::load_textures(&mut scene)?;
        Ok(scene)
    }
}
