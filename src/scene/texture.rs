//! Image textures: what a material names ([`TextureRef`]: a file, what it is
//! read for, its UV transform) and the images decoded once per scene
//! ([`TextureImage`], in [`Scene::textures`]), in the texel formats the
//! renderers read (`crate::math::texture`, `glsl/texture.glsl`). The scene
//! readers only name files; [`load_textures`] decodes them all at the end of a
//! load, and gives the triangles of meshes without UVs an untextured material.

use std::path::{Path, PathBuf};

use glam::{DVec3, Vec3};

use super::{Scene, SceneError};
use crate::shared;

/// How a texture's texels are read.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum TextureUse {
    /// RGB reflectance that multiplies the albedo: 8-bit images are sRGB-encoded
    /// (decoded on lookup), others linear; clamped to [0, 1].
    Colour,
    /// GGX roughness (times the material's `roughness`), from one channel: each
    /// texel's value sRGB-decoded where `srgb` (integer images only), times
    /// `scale`, then 1 - v where `invert` (pbrt-v4's order), then mapped by
    /// `remap`, before filtering.
    Roughness { channel: Channel, srgb: bool, scale: Factor, invert: bool, remap: Remap },
    /// A grey value in [0, 1] (pbrt's float `imagemap` as an operand of a
    /// procedural texture): read as a roughness of `Remap::Identity` is, in every
    /// channel.
    Float { srgb: bool, scale: Factor, invert: bool },
}

impl TextureUse {
    /// A roughness read as it is: linear, unscaled, not inverted, of `channel`
    /// and `remap`.
    pub const fn roughness(channel: Channel, remap: Remap) -> TextureUse {
        TextureUse::Roughness { channel, srgb: false, scale: Factor(1.0), invert: false, remap }
    }
}

/// A number in a [`TextureUse`], compared and hashed by its bits.
#[derive(Clone, Copy, Debug)]
pub struct Factor(pub f32);

impl PartialEq for Factor {
    fn eq(&self, other: &Factor) -> bool {
        self.0.to_bits() == other.0.to_bits()
    }
}

impl Eq for Factor {}

impl std::hash::Hash for Factor {
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        self.0.to_bits().hash(state)
    }
}

/// The channel a roughness texture is read from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Channel {
    /// The mean of red, green and blue (grey images; pbrt's float textures).
    Average,
    /// Green (glTF's `metallicRoughnessTexture`).
    Green,
}

/// From a roughness texel's value v to rlpt's roughness (alpha = roughness^2).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Remap {
    /// v is the roughness (TOML, glTF).
    Identity,
    /// v is GGX alpha: roughness sqrt(v) (pbrt with `remaproughness false`).
    Alpha,
    /// pbrt-v4's remap, alpha = sqrt(v): roughness v^(1/4).
    PbrtV4,
    /// pbrt-v3's polynomial remap of v to alpha, then sqrt.
    PbrtV3,
}

impl Remap {
    /// rlpt's roughness of a texel's value `v` in [0, 1].
    pub fn roughness(self, v: f32) -> f32 {
        let v = v.clamp(0.0, 1.0);
        match self {
            Remap::Identity => v,
            Remap::Alpha => v.sqrt(),
            Remap::PbrtV4 => v.sqrt().sqrt(),
            Remap::PbrtV3 => {
                let x = v.max(1e-3).ln();
                let alpha = 1.62142 + 0.819955 * x + 0.1734 * x * x + 0.0171201 * x.powi(3) + 0.000640711 * x.powi(4);
                alpha.clamp(0.0, 1.0).sqrt()
            }
        }
    }
}

/// A texture a material names: the image file, where it was named (for
/// errors), how it is read and its UV transform.
#[derive(Clone, Debug, PartialEq)]
pub struct TextureRef {
    /// The file as resolved (against the naming file's directory).
    pub path: PathBuf,
    /// The file name as written.
    pub written: String,
    /// The file that names it, and the 1-based line and column there, if known.
    pub origin: String,
    pub position: Option<(usize, usize)>,
    pub usage: TextureUse,
    /// st = (u * x + z, v * y + w): pbrt's `uscale`, `vscale`, `udelta`, `vdelta`.
    pub transform: [f32; 4],
    /// The encoded image itself, where a file embeds it (a glTF bufferView or
    /// `data:` uri); then `path` names it (`model.glb#images[0]`) and is no file.
    pub embedded: Option<Embedded>,
}

/// The bytes of an image embedded in a scene's file (PNG, JPEG, ...).
#[derive(Clone, PartialEq)]
pub struct Embedded(pub std::sync::Arc<[u8]>);

impl std::fmt::Debug for Embedded {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Embedded({} bytes)", self.0.len())
    }
}

impl TextureRef {
    /// A texture `written` in `origin` (at `position`), resolved against `base`,
    /// with the identity UV transform.
    pub fn new(written: &str, base: &Path, origin: &str, position: Option<(usize, usize)>, usage: TextureUse) -> Self {
        TextureRef {
            path: base.join(written),
            written: written.to_string(),
            origin: origin.to_string(),
            position,
            usage,
            transform: [1.0, 1.0, 0.0, 0.0],
            embedded: None,
        }
    }

    /// Image `index` embedded in `file` (`bytes`), for `usage`.
    pub fn embedded(file: &Path, index: usize, bytes: Vec<u8>, usage: TextureUse) -> Self {
        TextureRef {
            path: PathBuf::from(format!("{}#images[{index}]", file.display())),
            written: format!("images[{index}]"),
            origin: file.display().to_string(),
            position: None,
            usage,
            transform: [1.0, 1.0, 0.0, 0.0],
            embedded: Some(Embedded(bytes.into())),
        }
    }

    /// `"wood.png"`, with `(resolved to dir/wood.png)` where that differs.
    pub fn shown(&self) -> String {
        if self.embedded.is_some() {
            format!("\"{}\" (embedded in {})", self.written, self.origin)
        } else if self.path.as_os_str() == self.written.as_str() {
            format!("\"{}\"", self.written)
        } else {
            format!("\"{}\" (resolved to {})", self.written, self.path.display())
        }
    }

    fn error(&self, message: String) -> SceneError {
        SceneError::Invalid { file: self.origin.clone(), position: self.position, message }
    }
}

/// An image decoded for one use, as the renderers read it.
#[derive(Clone, Debug, PartialEq)]
pub struct TextureImage {
    pub path: PathBuf,
    pub usage: TextureUse,
    pub width: u32,
    pub height: u32,
    /// `shared::TEXEL_*`.
    pub format: u32,
    /// Rows from the image's top: one word per texel (RGBA8, red the low byte)
    /// or two (RGBA as halves).
    pub texels: Vec<u32>,
    /// The mean linear value of the texels as read (RGB; roughness in each).
    pub mean: Vec3,
}

/// Largest texture side: texel indices stay within 32 bits with room to spare.
pub const MAX_TEXTURE_SIDE: u32 = 32768;

/// sRGB's transfer function inverted: the linear value of an encoded one in [0, 1].
/// `glsl/texture.glsl` `srgb_to_linear` is its twin.
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Two halves in one word, as GLSL's `packHalf2x16` (a the low half).
pub fn pack_half2(a: f32, b: f32) -> u32 {
    half::f16::from_f32(a).to_bits() as u32 | (half::f16::from_f32(b).to_bits() as u32) << 16
}

/// Decodes the image of `r` for its use; the error names the file as written
/// and resolved, and where it was named.
pub fn decode(r: &TextureRef) -> Result<TextureImage, SceneError> {
    let image = match &r.embedded {
        Some(Embedded(bytes)) => image::load_from_memory(bytes),
        None if !r.path.is_file() => {
            return Err(r.error(format!("the texture image {} does not exist", r.shown())));
        }
        None => image::open(&r.path),
    };
    let image = image.map_err(|e| r.error(format!("the texture image {} cannot be read: {e}", r.shown())))?;
    let (width, height) = (image.width(), image.height());
    if width == 0 || height == 0 || width > MAX_TEXTURE_SIDE || height > MAX_TEXTURE_SIDE {
        return Err(r.error(format!(
            "the texture image {} is {width}x{height}; expected each side from 1 to {MAX_TEXTURE_SIDE}",
            r.shown()
        )));
    }
    use image::DynamicImage as D;
    let eight_bit = matches!(image, D::ImageLuma8(_) | D::ImageLumaA8(_) | D::ImageRgb8(_) | D::ImageRgba8(_));
    let float = matches!(image, D::ImageRgb32F(_) | D::ImageRgba32F(_));
    let n = width as usize * height as usize;
    let mut sum = DVec3::ZERO;
    let (format, texels) = match r.usage {
        TextureUse::Colour if eight_bit => {
            let rgba = image.to_rgba8();
            for p in rgba.pixels() {
                sum += DVec3::new(lin8(p[0]), lin8(p[1]), lin8(p[2]));
            }
            (shared::TEXEL_RGBA8_SRGB, rgba.pixels().map(|p| u32::from_le_bytes(p.0)).collect())
        }
        TextureUse::Colour => {
            // 16-bit integer images are sRGB-encoded too, float ones linear.
            let rgba = image.to_rgba32f();
            let mut texels = Vec::with_capacity(2 * n);
            for p in rgba.pixels() {
                let c = p.0.map(|c| {
                    let c = if c.is_finite() { c.clamp(0.0, 1.0) } else { 0.0 };
                    if float {
                        c
                    } else {
                        srgb_to_linear(c)
                    }
                });
                let h = |x: f32| half::f16::from_f32(x).to_f32() as f64;
                sum += DVec3::new(h(c[0]), h(c[1]), h(c[2]));
                texels.push(pack_half2(c[0], c[1]));
                texels.push(pack_half2(c[2], c[3]));
            }
            (shared::TEXEL_RGBA16F, texels)
        }
        TextureUse::Roughness { .. } | TextureUse::Float { .. } => {
            let (channel, srgb, scale, invert, remap) = match r.usage {
                TextureUse::Roughness { channel, srgb, scale, invert, remap } => (channel, srgb, scale, invert, remap),
                TextureUse::Float { srgb, scale, invert } => (Channel::Average, srgb, scale, invert, Remap::Identity),
                TextureUse::Colour => unreachable!(),
            };
            let rgba = image.to_rgba32f();
            let decode = |c: f32| if srgb && !float { srgb_to_linear(c) } else { c };
            let mut texels = Vec::with_capacity(n);
            for p in rgba.pixels() {
                let v = match channel {
                    Channel::Average => (decode(p[0]) + decode(p[1]) + decode(p[2])) / 3.0,
                    Channel::Green => decode(p[1]),
                } * scale.0;
                let v = if invert { 1.0 - v } else { v };
                let v = if v.is_finite() { v.clamp(0.0, 1.0) } else { 0.0 };
                let byte = (remap.roughness(v) * 255.0).round() as u8;
                sum += DVec3::splat(byte as f64 / 255.0);
                texels.push(u32::from_le_bytes([byte; 4]));
            }
            (shared::TEXEL_RGBA8, texels)
        }
    };
    Ok(TextureImage {
        path: r.path.clone(),
        usage: r.usage,
        width,
        height,
        format,
        texels,
        mean: (sum / n as f64).as_vec3(),
    })
}

fn lin8(b: u8) -> f64 {
    srgb_to_linear(b as f32 / 255.0) as f64
}

/// The index in `textures` of the image `r` reads, if decoded.
pub fn find(textures: &[TextureImage], r: &TextureRef) -> Option<usize> {
    textures.iter().position(|t| t.path == r.path && t.usage == r.usage)
}

/// Decodes every texture the scene's materials name (each file once per use)
/// into `scene.textures`; then gives the triangles of meshes without UVs whose
/// material has a texture a copy of that material without it, its albedo times
/// the texture's mean colour (its roughness times the mean roughness), noted.
pub fn load_textures(scene: &mut Scene) -> Result<(), SceneError> {
    for m in &scene.materials {
        let procedural = m.albedo_procedural.iter().flat_map(|p| p.images());
        for r in [&m.albedo_texture, &m.roughness_texture].into_iter().flatten().chain(procedural) {
            if find(&scene.textures, r).is_none() {
                scene.textures.push(decode(r)?);
            }
        }
    }
    if !(0..scene.materials.len() as u32).any(|m| reads_texture(&scene.materials, m)) {
        return Ok(());
    }
    let mut copies = std::collections::HashMap::new();
    for i in 0..scene.meshes.len() {
        if scene.meshes[i].uvs.is_some() {
            continue;
        }
        let mut named = Vec::new();
        for t in 0..scene.meshes[i].materials.len() {
            let m = scene.meshes[i].materials[t];
            if !reads_texture(&scene.materials, m) {
                continue;
            }
            if !named.contains(&m) {
                named.push(m);
            }
            scene.meshes[i].materials[t] = untextured(scene, m, &mut copies);
        }
        for m in named {
            let name = &scene.materials[m as usize].name;
            scene.notes.push(format!(
                "{}: has no texture coordinates, so its triangles of textured material `{name}` take the texture's \
                 mean in place of the texture",
                scene.meshes[i].source.display()
            ));
        }
    }
    Ok(())
}

/// Whether a hit on material `m` reads a texture: its own, or a mix's materials'.
fn reads_texture(materials: &[super::Material], m: u32) -> bool {
    let x = &materials[m as usize];
    x.textured() || x.mix.is_some_and(|[a, b]| reads_texture(materials, a) || reads_texture(materials, b))
}

/// The copy of material `m` without textures (made once, in `copies`): its
/// albedo times the texture's mean colour, its roughness times the mean
/// roughness; a mix's copy names its materials' copies.
fn untextured(scene: &mut Scene, m: u32, copies: &mut std::collections::HashMap<u32, u32>) -> u32 {
    if let Some(&c) = copies.get(&m) {
        return c;
    }
    if !reads_texture(&scene.materials, m) {
        return m;
    }
    let material = &scene.materials[m as usize];
    let mut plain = material.clone();
    if let Some(r) = plain.albedo_texture.take() {
        plain.albedo = (plain.albedo * scene.textures[find(&scene.textures, &r).unwrap()].mean).min(Vec3::ONE);
    }
    if let Some(p) = plain.albedo_procedural.take() {
        plain.albedo = (plain.albedo * p.mean(&scene.textures)).min(Vec3::ONE);
    }
    if std::mem::take(&mut plain.reflectance_conductor) {
        (plain.eta, plain.k, plain.albedo) = (Vec3::ONE, super::conductor_k(plain.albedo), Vec3::ONE);
    }
    if let Some(r) = plain.roughness_texture.take() {
        let mean = scene.textures[find(&scene.textures, &r).unwrap()].mean.x;
        plain.roughness = (plain.roughness * mean).clamp(shared::TEXTURE_MIN_ROUGHNESS, 1.0);
    }
    plain.name = format!("{} (untextured)", material.name);
    if let Some([a, b]) = plain.mix {
        plain.mix = Some([untextured(scene, a, copies), untextured(scene, b, copies)]);
    }
    scene.materials.push(plain);
    let c = scene.materials.len() as u32 - 1;
    copies.insert(m, c);
    c
}

/// One line per texture for `rlpt info`: its file, use, size and memory.
pub fn describe(textures: &[TextureImage]) -> Vec<String> {
    textures
        .iter()
        .map(|t| {
            let what = match t.usage {
                TextureUse::Colour => "colour".to_string(),
                TextureUse::Roughness { srgb, scale, invert, remap, .. } => {
                    let mut w = format!("roughness, {remap:?} remap");
                    w += if srgb { ", sRGB-decoded" } else { "" };
                    if scale.0 != 1.0 {
                        w += &format!(", scale {}", scale.0);
                    }
                    w + if invert { ", inverted" } else { "" }
                }
                TextureUse::Float { srgb, scale, invert } => {
                    let mut w = "grey".to_string();
                    w += if srgb { ", sRGB-decoded" } else { "" };
                    if scale.0 != 1.0 {
                        w += &format!(", scale {}", scale.0);
                    }
                    w + if invert { ", inverted" } else { "" }
                }
            };
            let format = match t.format {
                shared::TEXEL_RGBA8_SRGB => "RGBA8 sRGB",
                shared::TEXEL_RGBA16F => "RGBA16F",
                _ => "RGBA8 linear",
            };
            format!(
                "{} ({what}): {}x{} {format}, {:.1} MB",
                t.path.display(),
                t.width,
                t.height,
                4.0 * t.texels.len() as f64 / 1e6
            )
        })
        .collect()
}
