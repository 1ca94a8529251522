//! pbrt's `Texture` directive: `imagemap` images (read per hit where a
//! material's reflectance or roughness takes them), `constant`, and the
//! procedural `checkerboard`, `scale` and `mix` over constants and images
//! (`crate::scene::procedural`); what is not evaluated keeps its mean colour
//! where it has one, noted where a parameter takes it (`docs/pbrt.md`).

use glam::Vec3;

use super::images;
use super::lexer::Loc;
use super::material::Reader;
use super::params::Params;
use super::Importer;
use crate::scene::procedural::{Combine, Operand, Procedural};
use crate::scene::texture::Factor;
use crate::scene::{Material, SceneError, TextureRef, TextureUse};

/// A `Texture` as the materials see it: an `imagemap`'s image (a reflectance
/// reads a colour one as a texture, a roughness a float one), else its mean
/// colour where it has one.
#[derive(Clone, Debug)]
pub(crate) struct Texture {
    /// The colour image, with its UV transform (a `spectrum` `imagemap`).
    pub image: Option<TextureRef>,
    /// The float image (a `float` `imagemap`): how its texels are read.
    pub float_image: Option<FloatImage>,
    /// What multiplies the colour image: its `scale` (times a `scale` texture's constant).
    pub scale: Vec3,
    /// A checkerboard, scale or mix over constants and images, read per hit as a
    /// reflectance.
    pub procedural: Option<Procedural>,
    pub mean: Option<Vec3>,
    /// A `constant` texture: `mean` is its value, exact.
    pub constant: bool,
    pub loc: Loc,
    /// Why there is no mean, or where it came from (for the note).
    pub detail: String,
}

impl Texture {
    /// A texture read as its `mean` alone (None: not at all), `detail` saying why.
    pub fn stand_in(mean: Option<Vec3>, loc: &Loc, detail: String) -> Texture {
        Texture {
            image: None,
            float_image: None,
            scale: Vec3::ONE,
            procedural: None,
            mean,
            constant: false,
            loc: loc.clone(),
            detail,
        }
    }
}

/// A reflectance parameter as [`Reader::reflectance`] reads it: `value` times
/// the image or procedural texture at each hit, where there is one.
pub(crate) struct Reflectance {
    pub value: Vec3,
    pub image: Option<TextureRef>,
    pub procedural: Option<Procedural>,
}

impl Reflectance {
    /// Sets `m`'s textures to these (its albedo is set by the caller).
    pub fn texture(self, m: &mut Material) {
        (m.albedo_texture, m.albedo_procedural) = (self.image, self.procedural);
    }

    pub fn textured(&self) -> bool {
        self.image.is_some() || self.procedural.is_some()
    }
}

/// A float `imagemap` as a roughness reads it: the image (with its UV
/// transform) and pbrt's per-texel `encoding`, `scale` and `invert`.
#[derive(Clone, Debug)]
pub(crate) struct FloatImage {
    pub image: TextureRef,
    pub srgb: bool,
    pub scale: f32,
    pub invert: bool,
}

impl Importer {
    /// `Texture`: an `imagemap`'s image with its UV transform (and its mean
    /// colour, for parameters that take it as one); a missing image may be
    /// found under another image extension nearby, noted.
    pub(super) fn texture(&mut self, ty: &str, class: &str, p: &Params, loc: &Loc) -> Result<Texture, SceneError> {
        for name in ["filter", "maxanisotropy", "trilinear"] {
            p.touch(name);
        }
        let texture = match class {
            "imagemap" => {
                let f = p
                    .string("filename")?
                    .ok_or_else(|| loc.error("Texture \"imagemap\": missing \"string filename\""))?;
                let mut path = self.base.join(&f);
                let mut detail = format!("the mean of {}", path.display());
                if !path.is_file() {
                    match images::substitute(&path) {
                        Some(found) => {
                            self.notes.approximated(
                                loc,
                                format!(
                                    "texture image \"{f}\" ({}) is missing; {} has the same name and is read instead",
                                    path.display(),
                                    found.display()
                                ),
                            )?;
                            detail = format!("the mean of {}, standing in for the missing \"{f}\"", found.display());
                            path = found;
                        }
                        None => {
                            return Ok(Texture::stand_in(
                                None,
                                loc,
                                format!("\"{f}\" does not exist (resolved to {})", path.display()),
                            ))
                        }
                    }
                }
                let srgb = match (p.string("encoding")?, p.bool("gamma")?) {
                    (Some(e), _) => Some(e == "sRGB"),
                    (None, Some(g)) => Some(g),
                    _ => None,
                };
                // A float image's integer texels are sRGB-decoded as pbrt does: where
                // the file says so, else for PNG (pbrt-v3 and v4) and TGA (pbrt-v3).
                let ext = path.extension().map(|e| e.to_string_lossy().to_lowercase()).unwrap_or_default();
                let float_srgb = srgb.unwrap_or(ext == "png" || ext == "tga");
                let scale = p.float_or("scale", 1.0)? as f32;
                let invert = p.bool("invert")?.unwrap_or(false);
                let wrap = p.string("wrap")?.unwrap_or_else(|| "repeat".into());
                if wrap != "repeat" {
                    self.notes.approximated(loc, format!("Texture \"imagemap\": wrap \"{wrap}\" read as repeat"))?;
                }
                let mapping = p.string("mapping")?.unwrap_or_else(|| "uv".into());
                if mapping != "uv" {
                    self.notes.approximated(
                        loc,
                        format!("Texture \"imagemap\": mapping \"{mapping}\" read as \"uv\" (the shapes' own UVs)"),
                    )?;
                }
                let transform = [
                    p.float_or("uscale", 1.0)? as f32,
                    p.float_or("vscale", 1.0)? as f32,
                    p.float_or("udelta", 0.0)? as f32,
                    p.float_or("vdelta", 0.0)? as f32,
                ];
                if transform.iter().any(|x| !x.is_finite()) {
                    return Err(loc.error(format!(
                        "Texture \"imagemap\": uscale, vscale, udelta, vdelta {transform:?} must be finite"
                    )));
                }
                // The renderers read 8-bit images as sRGB and others as linear; a
                // reflectance of another encoding, or inverted, keeps its mean.
                let eight_bit = images::eight_bit(&path);
                let as_read = srgb.is_none_or(|s| Some(s) == eight_bit);
                // The image read: the stand-in where the file named is missing.
                let read = TextureRef {
                    path: path.clone(),
                    transform,
                    ..TextureRef::new(
                        &f,
                        &self.base,
                        &loc.file,
                        Some((loc.line, loc.column)),
                        crate::scene::TextureUse::Colour,
                    )
                };
                let image = (ty != "float" && as_read && !invert).then(|| read.clone());
                let float_image =
                    (ty == "float").then_some(FloatImage { image: read, srgb: float_srgb, scale, invert });
                if ty != "float" && image.is_none() {
                    let why = if invert {
                        "\"invert\" on a colour image".to_string()
                    } else {
                        "an encoding other than the file's (rlpt reads 8-bit images as sRGB, others as linear)".into()
                    };
                    self.notes.approximated(loc, format!("Texture \"imagemap\": {why}: taken as its mean colour"))?;
                }
                let float_file = matches!(ext.as_str(), "exr" | "hdr" | "pfm");
                let mean_srgb = if ty == "float" { Some(float_srgb && !float_file) } else { srgb };
                match images::mean(&path, mean_srgb, false) {
                    Ok(mean) => {
                        let mean = mean * scale;
                        let mean = if invert { Vec3::ONE - mean } else { mean };
                        Texture {
                            image,
                            float_image,
                            scale: Vec3::splat(scale),
                            ..Texture::stand_in(Some(mean), loc, detail)
                        }
                    }
                    Err(why) => {
                        if image.is_some() || float_image.is_some() {
                            return Err(loc.error(format!("texture image \"{f}\" ({}) {why}", path.display())));
                        }
                        Texture::stand_in(None, loc, format!("{} {why}", path.display()))
                    }
                }
            }
            "constant" => {
                let mut r = self.reader(p, loc, "Texture \"constant\"".into());
                let v = r.colour("value", Vec3::ONE)?;
                Texture { constant: true, ..Texture::stand_in(Some(v), loc, "a constant".into()) }
            }
            "checkerboard" | "scale" | "mix" => self.procedural(class, p, loc)?,
            _ => {
                for q in &p.list {
                    p.touch(&q.name);
                }
                Texture::stand_in(None, loc, format!("rlpt does not evaluate \"{class}\" textures"))
            }
        };
        let unused: Vec<String> = p.unused().map(|q| q.label()).collect();
        if !unused.is_empty() {
            self.notes.approximated(loc, format!("Texture \"{class}\": ignored {}", unused.join(", ")))?;
        }
        Ok(texture)
    }
}

impl Importer {
    /// `checkerboard` (2D, uv mapping), `scale` (pbrt-v4's `tex` times `scale`,
    /// pbrt-v3's `tex1` times `tex2`) and `mix` (`tex1`, `tex2` by `amount`) over
    /// constants and image textures; a constant times an image or constants alone
    /// fold into an image or a constant as pbrt folds them. An operand that is
    /// itself procedural (or unreadable) takes its mean, noted.
    fn procedural(&mut self, class: &str, p: &Params, loc: &Loc) -> Result<Texture, SceneError> {
        let what = format!("Texture \"{class}\"");
        let mut r = self.reader(p, loc, what.clone());
        let (combine, names, defaults): (Combine, [&str; 3], [f32; 3]) = match class {
            "checkerboard" => {
                for n in ["aamode", "dimension", "mapping", "uscale", "vscale", "udelta", "vdelta"] {
                    r.params.touch(n);
                }
                let dimension = r.params.integer("dimension")?.unwrap_or(2);
                if dimension != 2 && dimension != 3 {
                    return Err(loc.error(format!("{what}: dimension {dimension}; pbrt has 2 and 3")));
                }
                let mapping = r.params.string("mapping")?.unwrap_or_else(|| "uv".into());
                if dimension == 3 || mapping != "uv" {
                    let (a, b) = (operand(&mut r, "tex1", 1.0)?, operand(&mut r, "tex2", 0.0)?);
                    let mean = 0.5 * (a.1 + b.1);
                    r.note(format!(
                        "a {} checkerboard (mapping \"{mapping}\") is not evaluated: its mean {} stands in",
                        if dimension == 3 { "3D" } else { "2D" },
                        text(mean)
                    ))?;
                    return Ok(Texture::stand_in(Some(mean), loc, "the mean of a checkerboard".into()));
                }
                let transform = [
                    r.params.float_or("uscale", 1.0)? as f32,
                    r.params.float_or("vscale", 1.0)? as f32,
                    r.params.float_or("udelta", 0.0)? as f32,
                    r.params.float_or("vdelta", 0.0)? as f32,
                ];
                if transform.iter().any(|x| !x.is_finite()) {
                    return Err(
                        loc.error(format!("{what}: uscale, vscale, udelta, vdelta {transform:?} must be finite"))
                    );
                }
                (Combine::Checker(transform), ["tex1", "tex2", ""], [1.0, 0.0, 0.0])
            }
            "scale" if r.params.list.iter().any(|q| q.name == "tex1" || q.name == "tex2") => {
                (Combine::Scale, ["tex1", "tex2", ""], [1.0, 1.0, 0.0])
            }
            "scale" => (Combine::Scale, ["tex", "scale", ""], [1.0, 1.0, 0.0]),
            _ => (Combine::Mix, ["tex1", "tex2", "amount"], [0.0, 1.0, 0.5]),
        };
        let (a, a_mean) = operand(&mut r, names[0], defaults[0])?;
        let (b, b_mean) = operand(&mut r, names[1], defaults[1])?;
        let (amount, amount_mean) = if names[2].is_empty() {
            (Operand::constant(Vec3::ZERO), Vec3::ZERO)
        } else {
            operand(&mut r, names[2], defaults[2])?
        };
        if amount.image.is_none() && !(0.0..=1.0).contains(&amount.value.x) {
            return Err(loc.error(format!("{what}: amount {} must be from 0 to 1", amount.value.x)));
        }
        let t = amount_mean.x;
        let mean = match combine {
            Combine::Checker(_) => 0.5 * (a_mean + b_mean),
            Combine::Scale => a_mean * b_mean,
            Combine::Mix => a_mean * (1.0 - t) + b_mean * t,
        };
        let detail = format!("the mean of a \"{class}\" texture");
        let folded = match (&combine, &a.image, &b.image) {
            (Combine::Scale, None, None) | (Combine::Mix, None, None) if amount.image.is_none() => {
                Some(Texture { constant: true, ..Texture::stand_in(Some(mean), loc, detail.clone()) })
            }
            // pbrt-v4 folds a constant scale into the image's.
            (Combine::Scale, Some(i), None) | (Combine::Scale, None, Some(i)) if i.usage == TextureUse::Colour => {
                let scale = a.value * b.value;
                Some(Texture { image: Some(i.clone()), scale, ..Texture::stand_in(Some(mean), loc, detail.clone()) })
            }
            _ => None,
        };
        if let Some(t) = folded {
            return Ok(t);
        }
        let procedural = Procedural { combine, a, b, amount };
        Ok(Texture { procedural: Some(procedural), ..Texture::stand_in(Some(mean), loc, detail) })
    }
}

fn text(v: Vec3) -> String {
    format!("[{}, {}, {}]", v.x, v.y, v.z)
}

/// Operand `name` of a procedural texture (default `default`): a number,
/// colour or spectrum (its value), a `constant` texture, a colour `imagemap`
/// (its scale times the image), a float one (read grey), or another texture
/// (its mean, noted). With its mean colour.
fn operand(r: &mut Reader<'_>, name: &str, default: f32) -> Result<(Operand, Vec3), SceneError> {
    let Some(p) = r.params.get(name, &["texture"]).cloned() else {
        let v = r.colour(name, Vec3::splat(default))?;
        if v.min_element() < 0.0 || !v.is_finite() {
            return Err(r.loc.error(format!("{}: \"{name}\" {} must be finite and not negative", r.what, text(v))));
        }
        if v.max_element() > 1.0 {
            r.note(format!("\"{name}\" {} above 1: the texture's colour is clamped to [0, 1] at each hit", text(v)))?;
        }
        return Ok((Operand::constant(v), v));
    };
    let tex = p.string()?;
    let Some(t) = r.textures.get(&tex).cloned() else {
        return Err(p.loc.error(format!("parameter {} names texture \"{tex}\", which is not defined", p.label())));
    };
    let mean = t.mean.unwrap_or(Vec3::splat(default));
    if let Some(image) = t.image {
        return Ok((Operand { value: t.scale, image: Some(image) }, mean));
    }
    if let Some(FloatImage { image, srgb, scale, invert }) = t.float_image {
        let usage = TextureUse::Float { srgb, scale: Factor(scale), invert };
        return Ok((Operand { value: Vec3::ONE, image: Some(TextureRef { usage, ..image }) }, mean));
    }
    if !t.constant {
        let why = if t.procedural.is_some() { "a procedural texture of a procedural texture" } else { &t.detail };
        r.note(format!(
            "{} is texture \"{tex}\" ({}), taken as its mean colour {} ({why}: rlpt evaluates procedural textures \
             over constants and images only)",
            p.label(),
            t.loc.at(),
            text(mean)
        ))?;
    }
    Ok((Operand::constant(mean), mean))
}
