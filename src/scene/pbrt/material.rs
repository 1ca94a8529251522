//! pbrt's materials (v4 names and v3 names) mapped onto rlpt's kinds by the
//! rules of `docs/pbrt.md`; what a mapping approximates is noted. `mix` is
//! in [`super::mix`].

use std::collections::HashMap;

use glam::Vec3;

use super::lexer::Loc;
use super::params::{Param, Params};
pub(crate) use super::texture::{FloatImage, Reflectance, Texture};
use super::{Importer, Notes};
use crate::scene::texture::{Channel, Factor, Remap};
use crate::scene::{conductor_k, Material, MaterialKind, SceneError, TextureRef, TextureUse};

/// A pbrt material mapped onto one of rlpt's, with the line `rlpt info` prints.
#[derive(Clone, Debug)]
pub(crate) struct Mapped {
    pub material: Material,
    pub mapping: String,
}

/// RGB eta and k of pbrt's named metal spectra (their values at the sRGB primaries).
const METALS: &[(&str, [f32; 3], [f32; 3])] = &[
    ("Cu", [0.200438, 0.924033, 1.10221], [3.91295, 2.45285, 2.14219]),
    ("Au", [0.143119, 0.374957, 1.44248], [3.98316, 2.38572, 1.60322]),
    ("Ag", [0.155265, 0.116723, 0.138342], [4.82835, 3.12225, 2.14696]),
    ("Al", [1.65746, 0.880369, 0.521229], [9.22387, 6.26952, 4.837]),
];

/// Index of refraction at 587.6 nm of pbrt's named glass spectra (pbrt reads F5, F10
/// and F11 from its tables of Schott SF5, SF10 and SF11).
const GLASSES: &[(&str, f32)] = &[
    ("glass-BK7", 1.5168),
    ("glass-BAF10", 1.67),
    ("glass-FK51A", 1.4866),
    ("glass-LASF9", 1.8503),
    ("glass-F5", 1.6727),
    ("glass-F10", 1.7283),
    ("glass-F11", 1.7847),
];

fn plain(kind: MaterialKind, albedo: Vec3) -> Material {
    Material::plain(String::new(), kind, albedo)
}

fn text(v: Vec3) -> String {
    format!("[{}, {}, {}]", v.x, v.y, v.z)
}

/// A reflectance for the mapping line: `Kd [r, g, b]`, or with an image
/// `Kd texture dir/wood.png` (times a scale other than 1), or a procedural one.
fn textured(key: &str, v: Vec3, r: &Reflectance) -> String {
    let times = if v == Vec3::ONE { String::new() } else { format!(" times {}", text(v)) };
    match (&r.image, &r.procedural) {
        (Some(t), _) => format!("{key} texture {}{times}", t.path.display()),
        (None, Some(p)) => format!("{key} {}{times}", p.describe()),
        (None, None) => format!("{key} {}", text(v)),
    }
}

/// Reads materials' parameters, noting what it approximates.
pub(crate) struct Reader<'a> {
    pub params: &'a Params,
    pub textures: &'a HashMap<String, Texture>,
    pub notes: &'a mut Notes,
    /// The directive's place, and the material's name for notes.
    pub loc: &'a Loc,
    pub what: String,
}

impl Reader<'_> {
    pub fn note(&mut self, message: String) -> Result<(), SceneError> {
        let m = format!("{}: {message}", self.what);
        self.notes.approximated(self.loc, m)
    }

    /// A colour parameter: rgb/color, a named or sampled spectrum, blackbody, a
    /// float, or a texture (its mean colour).
    pub fn colour(&mut self, name: &str, default: Vec3) -> Result<Vec3, SceneError> {
        let Some(p) = self.params.get(name, &["rgb", "color", "spectrum", "blackbody", "float", "texture"]) else {
            return Ok(default);
        };
        let p = p.clone();
        match p.ty.as_str() {
            "rgb" | "color" => {
                let v = p.numbers_n(3)?;
                Ok(Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32))
            }
            "float" => Ok(Vec3::splat(p.numbers_n(1)?[0] as f32)),
            "blackbody" => {
                self.note(format!("{}: a blackbody colour, taken as white (rlpt works in RGB)", p.label()))?;
                Ok(Vec3::ONE)
            }
            "texture" => self.texture(&p, default),
            _ => self.spectrum(&p),
        }
    }

    /// A reflectance parameter: a colour as [`Reader::colour`] reads it, or an
    /// `imagemap` texture, which the material reads at each hit: then its
    /// `scale` as the colour, and the image.
    pub fn reflectance(&mut self, name: &str, default: Vec3) -> Result<Reflectance, SceneError> {
        if let Some(p) = self.params.get(name, &["texture"]) {
            let p = p.clone();
            let tex = p.string()?;
            match self.textures.get(&tex) {
                Some(Texture { image: Some(image), scale, .. }) => {
                    return Ok(Reflectance { value: *scale, image: Some(image.clone()), procedural: None })
                }
                Some(Texture { procedural: Some(procedural), .. }) => {
                    return Ok(Reflectance { value: Vec3::ONE, image: None, procedural: Some(procedural.clone()) })
                }
                _ => {}
            }
        }
        Ok(Reflectance { value: self.colour(name, default)?, image: None, procedural: None })
    }

    fn texture(&mut self, p: &Param, default: Vec3) -> Result<Vec3, SceneError> {
        let name = p.string()?;
        let Some(t) = self.textures.get(&name) else {
            return Err(p.loc.error(format!("parameter {} names texture \"{name}\", which is not defined", p.label())));
        };
        let t = t.clone();
        match t.mean {
            Some(mean) => {
                self.note(format!(
                    "{} is texture \"{name}\" ({}), taken as its mean colour {} ({}; rlpt reads image textures as \
                     reflectances and roughnesses alone)",
                    p.label(),
                    t.loc.at(),
                    text(mean),
                    t.detail
                ))?;
                Ok(mean)
            }
            None => {
                self.note(format!(
                    "{} is texture \"{name}\" ({}), which rlpt cannot read ({}); the default {} stands in",
                    p.label(),
                    t.loc.at(),
                    t.detail,
                    text(default)
                ))?;
                Ok(default)
            }
        }
    }

    /// A `spectrum` value: a named metal (`metal-Cu-eta`), or wavelength/value
    /// pairs (averaged, noted).
    fn spectrum(&mut self, p: &Param) -> Result<Vec3, SceneError> {
        if let Ok(name) = p.string() {
            for (metal, eta, k) in METALS {
                if name == format!("metal-{metal}-eta") {
                    return Ok(Vec3::from(*eta));
                }
                if name == format!("metal-{metal}-k") {
                    return Ok(Vec3::from(*k));
                }
            }
            if let Some((_, ior)) = GLASSES.iter().find(|(g, _)| *g == name) {
                return Ok(Vec3::splat(*ior));
            }
            let known: Vec<String> = METALS.iter().map(|m| format!("metal-{}-eta/k", m.0)).collect();
            return Err(p.loc.error(format!(
                "parameter {} names spectrum \"{name}\", which rlpt does not know; it knows {} and {}",
                p.label(),
                known.join(", "),
                GLASSES.iter().map(|g| g.0).collect::<Vec<_>>().join(", ")
            )));
        }
        let v = p.numbers()?;
        if v.len() < 2 || v.len() % 2 != 0 {
            return Err(p.loc.error(format!(
                "parameter {} must be a spectrum name or wavelength/value pairs, found {} numbers",
                p.label(),
                v.len()
            )));
        }
        let values: Vec<f64> = v.chunks(2).map(|c| c[1]).collect();
        let mean = (values.iter().sum::<f64>() / values.len() as f64) as f32;
        self.note(format!("{}: a sampled spectrum, taken as its mean value {mean} (rlpt works in RGB)", p.label()))?;
        Ok(Vec3::splat(mean))
    }

    /// A float parameter: a number, a `constant` texture's value, or another
    /// texture's mean (noted; a roughness reads a float image itself, [`Reader::rough`]).
    pub fn scalar(&mut self, name: &str, default: f64) -> Result<f64, SceneError> {
        match self.params.get(name, &["float", "texture"]) {
            None => Ok(default),
            Some(p) if p.ty == "texture" => {
                let p = p.clone();
                let tex = p.string()?;
                match self.textures.get(&tex) {
                    Some(t) if t.constant => Ok(t.mean.map_or(default, |m| m.x as f64)),
                    _ => Ok(self.texture(&p, Vec3::splat(default as f32))?.x as f64),
                }
            }
            Some(p) => Ok(p.numbers_n(1)?[0]),
        }
    }

    /// The float image a parameter names, if it names a float `imagemap`.
    fn float_image(&self, name: &str) -> Result<Option<(String, FloatImage)>, SceneError> {
        let Some(p) = self.params.get(name, &["texture"]) else { return Ok(None) };
        let tex = p.string()?;
        Ok(self.textures.get(&tex).and_then(|t| t.float_image.clone()).map(|f| (tex, f)))
    }

    /// An albedo in [0, 1]: negative components refused, larger ones clamped (noted).
    fn albedo(&mut self, v: Vec3, what: &str) -> Result<Vec3, SceneError> {
        if v.min_element() < 0.0 {
            return Err(self.loc.error(format!("{}: {what} {} has a negative component", self.what, text(v))));
        }
        if v.max_element() > 1.0 {
            self.note(format!("{what} {} clamped to [0, 1]", text(v)))?;
        }
        Ok(v.clamp(Vec3::ZERO, Vec3::ONE))
    }

    /// rlpt's roughness from roughness parameters (`prefix` "conductor." for
    /// coatedconductor), with the alpha it comes from, or a roughness texture
    /// (a float `imagemap`; then roughness 1, its factor). u and v roughness are
    /// `roughness` unless given; their geometric mean where they differ (noted);
    /// a texture of one read for both (noted where the other differs).
    /// Remapped as pbrt-v4 (`sqrt`) or pbrt-v3 (its polynomial) where
    /// `remaproughness` (default true).
    fn rough(&mut self, prefix: &str, default: f64, v3: bool, smooth_at_zero: bool) -> Result<Rough, SceneError> {
        let [r, u, v] = ["roughness", "uroughness", "vroughness"].map(|n| format!("{prefix}{n}"));
        let remap = self.params.bool("remaproughness")?.unwrap_or(true);
        let given = |n: &str| self.params.get(n, &["float", "texture"]).is_some();
        let (u_name, v_name) = (if given(&u) { &u } else { &r }, if given(&v) { &v } else { &r });
        let (u_image, v_image) = (self.float_image(u_name)?, self.float_image(v_name)?);
        if let Some((tex, image)) = u_image.clone().or(v_image.clone()) {
            for n in [&r, &u, &v] {
                self.params.touch(n);
            }
            let other = if u_image.is_some() { v_name } else { u_name };
            if u_image.as_ref().zip(v_image.as_ref()).is_none_or(|(a, b)| a.0 != b.0) {
                let read = if u_image.is_some() { u_name } else { v_name };
                let other = match self.params.get(other, &["float", "texture"]) {
                    Some(p) => p.label(),
                    None => format!("\"{other}\" (not given: its default)"),
                };
                self.note(format!(
                    "{other} dropped: rlpt's roughness is isotropic, and the texture \"{tex}\" of {read} is read for \
                     both directions"
                ))?;
            }
            let remap = match (remap, v3) {
                (false, _) => Remap::Alpha,
                (true, false) => Remap::PbrtV4,
                (true, true) => Remap::PbrtV3,
            };
            let usage = TextureUse::Roughness {
                channel: Channel::Average,
                srgb: image.srgb,
                scale: Factor(image.scale),
                invert: image.invert,
                remap,
            };
            let how = format!("roughness texture {} ({remap:?} remap)", image.image.path.display());
            return Ok(Rough {
                roughness: 1.0,
                alpha: f64::NAN,
                texture: Some(TextureRef { usage, ..image.image }),
                how,
            });
        }
        let r = self.scalar(&r, default)?;
        let u = self.scalar(&u, r)?;
        let v = self.scalar(&v, r)?;
        if u < 0.0 || v < 0.0 {
            return Err(self.loc.error(format!("{}: roughness must be >= 0, found {u} and {v}", self.what)));
        }
        let to_alpha = |r: f64| match (remap, v3) {
            (false, _) => r,
            (true, false) => r.sqrt(),
            (true, true) => {
                let x = r.max(1e-3).ln();
                1.62142 + 0.819955 * x + 0.1734 * x * x + 0.0171201 * x.powi(3) + 0.000640711 * x.powi(4)
            }
        };
        // pbrt-v3's glass is smooth at roughness 0 before any remapping.
        let alpha = if smooth_at_zero && u == 0.0 && v == 0.0 {
            0.0
        } else {
            let (au, av) = (to_alpha(u), to_alpha(v));
            if (au - av).abs() > 1e-6 {
                self.note(format!(
                    "anisotropic roughness (alpha {au} by {av}) taken as isotropic alpha {}",
                    (au * av).sqrt()
                ))?;
            }
            (au * av).sqrt()
        };
        let roughness = self.roughness(alpha)?;
        let how = format!("alpha {} -> roughness {roughness}", alpha as f32);
        Ok(Rough { roughness, alpha, texture: None, how })
    }

    /// rlpt's roughness, sqrt(alpha), from a GGX alpha: 0 below pbrt-v4's
    /// "effectively smooth" alpha (1e-3), at most 1 (noted where clamped).
    fn roughness(&mut self, alpha: f64) -> Result<f32, SceneError> {
        if alpha < SMOOTH_ALPHA {
            return Ok(0.0);
        }
        if alpha > 1.0 {
            self.note(format!("GGX alpha {alpha} above 1, clamped to 1"))?;
            return Ok(1.0);
        }
        Ok(alpha.sqrt() as f32)
    }

    /// A conductor's complex index eta + i k: `reflectance` if given (as pbrt-v4,
    /// eta 1 and k = [`conductor_k`] of it), else `eta` and `k` (default copper).
    /// A reflectance texture (image or procedural) comes back to be read per hit,
    /// its constant factor as its `value`.
    /// pbrt-v4's coatedconductor names it `reflectance` (read as `conductor.reflectance` too).
    fn conductor(&mut self, prefix: &str) -> Result<(Vec3, Vec3, String, Option<Reflectance>), SceneError> {
        let kinds = ["rgb", "color", "spectrum", "float", "texture"];
        let prefixed = format!("{prefix}reflectance");
        let name = if self.params.get("reflectance", &kinds).is_some() { "reflectance".to_string() } else { prefixed };
        if self.params.get(&name, &["rgb", "color", "spectrum", "float", "texture"]).is_some() {
            let mut refl = self.reflectance(&name, Vec3::ONE)?;
            refl.value = self.albedo(refl.value, "reflectance")?;
            if refl.textured() {
                let from = format!("{} -> eta 1, k per hit", textured("reflectance", refl.value, &refl));
                return Ok((Vec3::ONE, Vec3::ZERO, from, Some(refl)));
            }
            let r = refl.value.min(Vec3::splat(0.9999));
            let k = conductor_k(r);
            return Ok((Vec3::ONE, k, format!("reflectance {} -> eta 1, k {}", text(r), text(k)), None));
        }
        let (cu_eta, cu_k) = (Vec3::from(METALS[0].1), Vec3::from(METALS[0].2));
        let eta = self.colour(&format!("{prefix}eta"), cu_eta)?;
        let k = self.colour(&format!("{prefix}k"), cu_k)?;
        if eta.min_element() <= 0.0 || k.min_element() < 0.0 || eta.max_element() > 100.0 || k.max_element() > 100.0 {
            return Err(self.loc.error(format!(
                "{}: eta {} must be in (0, 100] and k {} in [0, 100]",
                self.what,
                text(eta),
                text(k)
            )));
        }
        Ok((eta, k, format!("eta {} k {}", text(eta), text(k)), None))
    }
}

/// A material's roughness as [`Reader::rough`] reads it.
pub(crate) struct Rough {
    /// rlpt's roughness (sqrt(alpha)); 1 with a texture (its factor).
    pub roughness: f32,
    /// The GGX alpha of the parameters; NaN with a texture.
    pub alpha: f64,
    /// The float image the roughness is read from, per texel.
    pub texture: Option<TextureRef>,
    /// For the mapping line: `alpha 0.1 -> roughness 0.316`, or the texture.
    pub how: String,
}

/// GGX alpha below which pbrt-v4 treats a surface as smooth (`EffectivelySmooth`).
const SMOOTH_ALPHA: f64 = 1e-3;

/// The roughness of a conductor pbrt gives as smooth under a coat: rlpt's coated
/// conductor needs a GGX base, and sqrt(SMOOTH_ALPHA) is the roughest pbrt would
/// still call smooth.
const SMOOTH_BASE_ROUGHNESS: f32 = 0.0316;

/// An index of refraction `given` as a float, or as a spectrum (its first
/// channel, the dispersion dropped with a note); pbrt's 1.5 where not given.
fn index_of(r: &mut Reader<'_>, given: Option<Param>) -> Result<f32, SceneError> {
    Ok(match given {
        None => 1.5,
        Some(p) if p.ty == "float" => p.numbers_n(1)?[0] as f32,
        Some(p) => {
            let v = r.spectrum(&p)?;
            r.note(format!("{}: dispersion dropped, index {}", p.label(), v.x))?;
            v.x
        }
    })
}

/// pbrt-v4's `coatedconductor`: rlpt's coated material over a conductor base, the
/// coat of `interface.eta` and `interface.roughness` (smooth at 0), the base of
/// `conductor.eta`/`conductor.k` or `reflectance` and `conductor.roughness`
/// (a roughness texture read per hit); what it approximates is noted.
fn coated_conductor(r: &mut Reader<'_>) -> Result<(Material, String), SceneError> {
    let given = r.params.get("interface.eta", &["float", "spectrum"]).cloned();
    let ior = index_of(r, given)?;
    if !(1.0..=100.0).contains(&ior) {
        return Err(r.loc.error(format!("{}: interface.eta {ior} must be from 1 to 100 for a coat", r.what)));
    }
    let mut coat = r.rough("interface.", 0.0, false, false)?;
    if coat.texture.is_some() {
        // The one roughness texture a material has scales its base's roughness.
        let names = ["interface.uroughness", "interface.vroughness", "interface.roughness"];
        let name = names.into_iter().find(|n| r.params.get(n, &["texture"]).is_some()).unwrap_or(names[2]);
        let mean = r.scalar(name, 0.0)?;
        let alpha = if r.params.bool("remaproughness")?.unwrap_or(true) { mean.sqrt() } else { mean };
        r.note(format!(
            "the coat's roughness texture read as its mean, alpha {}: rlpt textures the base's roughness alone",
            alpha as f32
        ))?;
        coat = Rough { roughness: r.roughness(alpha)?, alpha, texture: None, how: String::new() };
    }
    let coat_how = if coat.roughness == 0.0 {
        format!("alpha {} -> a smooth coat", coat.alpha as f32)
    } else {
        format!("alpha {} -> roughness {}", coat.alpha as f32, coat.roughness)
    };
    let (eta, k, from, textured) = r.conductor("conductor.")?;
    let mut base = r.rough("conductor.", 0.0, false, false)?;
    if base.roughness == 0.0 && base.texture.is_none() {
        r.note(format!(
            "a smooth conductor under the coat (alpha {}) given roughness {SMOOTH_BASE_ROUGHNESS}: rlpt's base is GGX",
            base.alpha as f32
        ))?;
        base.roughness = SMOOTH_BASE_ROUGHNESS;
        base.how = format!("alpha {} -> roughness {SMOOTH_BASE_ROUGHNESS}", base.alpha as f32);
    }
    let mut m = plain(MaterialKind::Coated, Vec3::ONE);
    (m.ior, m.roughness, m.eta, m.k) = (ior, coat.roughness, eta, k);
    (m.base_roughness, m.roughness_texture) = (Some(base.roughness), base.texture);
    if let Some(refl) = textured {
        (m.albedo, m.reflectance_conductor) = (refl.value, true);
        refl.texture(&mut m);
    }
    Ok((m, format!("coat eta {ior}, {coat_how}; conductor {from}, {}", base.how)))
}

/// Maps material `ty` (its parameters in `r`) onto rlpt's; `mix` is the
/// importer's (it needs the named materials).
pub(crate) fn map(ty: &str, r: &mut Reader<'_>) -> Result<Mapped, SceneError> {
    let v3 = matches!(ty, "metal" | "glass" | "plastic" | "uber" | "substrate" | "translucent" | "mirror" | "matte");
    let (material, how) = match ty {
        "diffuse" | "matte" => {
            let key = if ty == "diffuse" { "reflectance" } else { "Kd" };
            let image = r.reflectance(key, Vec3::splat(0.5))?;
            let a = image.value;
            if ty == "matte" && r.scalar("sigma", 0.0)? != 0.0 {
                r.note("Oren-Nayar `sigma` dropped (Lambertian)".to_string())?;
            }
            let mut m = plain(MaterialKind::Diffuse, r.albedo(a, key)?);
            let how = textured(key, a, &image);
            image.texture(&mut m);
            (m, how)
        }
        "coatedconductor" => coated_conductor(r)?,
        "conductor" | "metal" => {
            let (eta, k, from, textured) = r.conductor("")?;
            let rough = r.rough("", if v3 { 0.01 } else { 0.0 }, v3, false)?;
            let mut m = plain(MaterialKind::Conductor, Vec3::ONE);
            (m.eta, m.k, m.roughness) = (eta, k, rough.roughness);
            if let Some(refl) = textured {
                (m.albedo, m.reflectance_conductor) = (refl.value, true);
                refl.texture(&mut m);
            }
            let how = if m.roughness == 0.0 { format!("alpha {} -> a mirror", rough.alpha as f32) } else { rough.how };
            m.roughness_texture = rough.texture;
            (m, format!("{from}, {how}"))
        }
        "mirror" => {
            let image = r.reflectance("Kr", Vec3::splat(0.9))?;
            let a = image.value;
            let mut m = plain(MaterialKind::Specular, r.albedo(a, "Kr")?);
            let how = textured("Kr", a, &image);
            image.texture(&mut m);
            (m, how)
        }
        "dielectric" | "glass" | "thindielectric" => {
            let given =
                r.params.get("eta", &["float", "spectrum"]).or_else(|| r.params.get("index", &["float"])).cloned();
            let eta = index_of(r, given)?;
            if eta < 1.0 {
                return Err(r.loc.error(format!("{}: eta {eta} below 1; rlpt's dielectrics need eta >= 1", r.what)));
            }
            let mut rough = r.rough("", 0.0, v3, true)?;
            if ty == "thindielectric" {
                r.note("thindielectric rendered as a solid dielectric".to_string())?;
                if rough.roughness > 0.0 {
                    r.note(format!("thindielectric's roughness ({}) dropped: rendered smooth", rough.how))?;
                    (rough.roughness, rough.texture) = (0.0, None);
                }
            }
            let mut albedo = Vec3::ONE;
            if ty == "glass" {
                let kr = r.colour("Kr", Vec3::ONE)?;
                albedo = r.colour("Kt", Vec3::ONE)?;
                if kr != Vec3::ONE || albedo != Vec3::ONE {
                    r.note(format!("Kr {} and Kt {}: Kt taken as the albedo, Kr dropped", text(kr), text(albedo)))?;
                }
                albedo = r.albedo(albedo, "Kt")?;
            }
            let mut m = plain(MaterialKind::Dielectric, albedo);
            m.ior = eta;
            if rough.roughness > 0.0 {
                (m.kind, m.roughness, m.roughness_texture) =
                    (MaterialKind::RoughDielectric, rough.roughness, rough.texture);
                (m, format!("eta {eta}, {}", rough.how))
            } else {
                (m, format!("eta {eta}"))
            }
        }
        "coateddiffuse" | "plastic" | "substrate" => {
            let (key, default) = if ty == "coateddiffuse" { ("reflectance", 0.5) } else { ("Kd", 0.25) };
            let default = if ty == "substrate" { 0.5 } else { default };
            let image = r.reflectance(key, Vec3::splat(default))?;
            let albedo = r.albedo(image.value, key)?;
            // pbrt-v3's plastic and substrate: a dielectric interface of index 1.5 over
            // the diffuse layer; their Ks scales what rlpt's coat reflects by its Fresnel.
            let ior = if ty == "coateddiffuse" { r.scalar("eta", 1.5)? as f32 } else { 1.5 };
            if !(1.0..=100.0).contains(&ior) {
                return Err(r.loc.error(format!("{}: eta {ior} must be from 1 to 100 for a coat", r.what)));
            }
            if ty != "coateddiffuse" && r.params.get("Ks", &["rgb", "color", "spectrum", "float", "texture"]).is_some()
            {
                let ks = r.colour("Ks", Vec3::ONE)?;
                r.note(format!("Ks {} dropped: the coat reflects by its Fresnel at index 1.5", text(ks)))?;
            }
            let default_roughness = if ty == "coateddiffuse" { 0.0 } else { 0.1 };
            let mut rough = r.rough("", default_roughness, v3, false)?;
            if rough.roughness == 0.0 && rough.texture.is_none() {
                rough.how = format!("alpha {} -> a smooth coat", rough.alpha as f32);
            }
            let mut m = plain(MaterialKind::Coated, albedo);
            (m.ior, m.roughness, m.roughness_texture) = (ior, rough.roughness, rough.texture);
            let how = format!("{}, eta {ior}, {}", textured(key, albedo, &image), rough.how);
            image.texture(&mut m);
            (m, how)
        }
        "interface" | "none" | "" => {
            r.note("no surface (a medium boundary): rendered as a dielectric of eta 1, which light passes straight through".to_string())?;
            let mut m = plain(MaterialKind::Dielectric, Vec3::ONE);
            m.ior = 1.0;
            (m, "eta 1 (invisible)".to_string())
        }
        _ => {
            let (key, default, what) = match ty {
                "diffusetransmission" => ("reflectance", 0.25, "its transmission dropped"),
                "uber" => ("Kd", 0.25, "its specular, mirror and transmission layers dropped"),
                "translucent" => ("Kd", 0.25, "its transmission dropped"),
                "subsurface" | "kdsubsurface" => ("reflectance", 0.5, "subsurface scattering dropped"),
                "measured" | "hair" | "fourier" => ("", 0.5, "not modelled at all"),
                _ => {
                    return Err(r.loc.error(format!(
                        "unknown material type \"{ty}\"; expected one of diffuse, conductor, dielectric, thindielectric, \
                         coateddiffuse, coatedconductor, diffusetransmission, measured, mix, hair, subsurface, interface \
                         (pbrt-v4) or matte, plastic, metal, glass, mirror, uber, substrate, translucent (pbrt-v3)"
                    )))
                }
            };
            let key = if ty == "kdsubsurface" { "Kd" } else { key };
            let image = if key.is_empty() {
                Reflectance { value: Vec3::splat(default), image: None, procedural: None }
            } else {
                r.reflectance(key, Vec3::splat(default))?
            };
            let a = image.value;
            r.note(format!("{ty} rendered as diffuse ({what})"))?;
            // The dropped layers' parameters are covered by that note.
            let names: Vec<String> = r.params.list.iter().map(|p| p.name.clone()).collect();
            for n in names {
                r.params.touch(&n);
            }
            let a = r.albedo(a, if key.is_empty() { "albedo" } else { key })?;
            let mut m = plain(MaterialKind::Diffuse, a);
            let how = textured(if key.is_empty() { "albedo" } else { key }, a, &image);
            image.texture(&mut m);
            (m, how)
        }
    };
    let kind = format!("{:?}", material.kind).to_lowercase();
    Ok(Mapped { material, mapping: format!("{ty} -> {kind} ({how})") })
}

impl Importer {
    /// A reader of the parameters `p` of the directive at `loc`, its notes
    /// naming `what`.
    pub(super) fn reader<'a>(&'a mut self, p: &'a Params, loc: &'a Loc, what: String) -> Reader<'a> {
        Reader { params: p, textures: &self.textures, notes: &mut self.notes, loc, what }
    }

    /// Maps a material, notes what it leaves out, and returns its index.
    pub(super) fn material(&mut self, ty: &str, p: &Params, loc: &Loc, label: &str) -> Result<usize, SceneError> {
        let mut mapped = if ty == "mix" {
            self.mix(p, loc, label)?
        } else {
            let mut r = self.reader(p, loc, format!("material \"{label}\""));
            map(ty, &mut r)?
        };
        let unused: Vec<String> = p.unused().map(|q| q.label()).collect();
        if !unused.is_empty() {
            self.notes.approximated(loc, format!("material \"{label}\" ({ty}): ignored {}", unused.join(", ")))?;
        }
        mapped.material.name = label.to_string();
        mapped.mapping = format!("{label}: {} [{}]", mapped.mapping, loc.at());
        self.materials.push(mapped);
        Ok(self.materials.len() - 1)
    }
}
