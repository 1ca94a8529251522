//! glTF materials mapped onto rlpt's (`docs/SCENE_FORMAT.md`, "Meshes"; the
//! rules in `gltf.rs`'s doc), with their image textures: `baseColorTexture`
//! (times `baseColorFactor`) and the roughness (green) channel of
//! `metallicRoughnessTexture` (times `roughnessFactor`), where the image is a
//! file beside the glTF or embedded in it (a bufferView, as in a `.glb`, or a
//! base64 `data:` uri) and the texture reads TEXCOORD_0.

use std::collections::HashMap;
use std::path::Path;

use glam::Vec3;

use super::{vec_text, FileMaterial, Ignored, SPECULAR_BELOW_ROUGHNESS};
use crate::scene::texture::{Channel, Remap, TextureRef, TextureUse};
use crate::scene::{Material, MaterialKind};

/// The encoded bytes of the embedded images a material's texture slots name
/// (a bufferView, read by `view_bytes`, or a `data:` uri), by image index;
/// else why they could not be had.
pub(super) type Embedded = HashMap<usize, Result<Vec<u8>, String>>;

/// The embedded images of `m`'s `baseColorTexture` and `metallicRoughnessTexture`.
pub(super) fn embedded_images(
    m: &gltf::Material<'_>,
    view_bytes: &mut dyn FnMut(&gltf::buffer::View<'_>) -> Result<Vec<u8>, String>,
) -> Embedded {
    let pbr = m.pbr_metallic_roughness();
    let mut out = Embedded::new();
    for info in [pbr.base_color_texture(), pbr.metallic_roughness_texture()].into_iter().flatten() {
        let image = info.texture().source();
        let bytes = match image.source() {
            gltf::image::Source::View { view, .. } => view_bytes(&view),
            gltf::image::Source::Uri { uri, .. } if uri.starts_with("data:") => super::gltf::decode_data_uri(uri)
                .ok_or_else(|| "its `data:` uri does not decode; expected `data:...;base64,` and base64 text".into()),
            gltf::image::Source::Uri { .. } => continue,
        };
        out.insert(image.index(), bytes);
    }
    out
}

/// Maps a glTF material onto rlpt's (this module's doc), its embedded images
/// in `embedded`; what it drops goes into `ignored`.
pub(super) fn map_material(
    m: &gltf::Material<'_>,
    index: usize,
    dir: &Path,
    file: &Path,
    embedded: &Embedded,
    ignored: &mut Ignored,
) -> FileMaterial {
    let name = m.name().filter(|n| !n.is_empty()).map_or_else(|| format!("material{index}"), str::to_string);
    let who = format!("materials[{index}] `{name}`");
    let pbr = m.pbr_metallic_roughness();
    let [r, g, b, _] = pbr.base_color_factor();
    let base = Vec3::new(r, g, b).clamp(Vec3::ZERO, Vec3::ONE);
    let strength = m.emissive_strength().unwrap_or(1.0);
    let emission = (Vec3::from(m.emissive_factor()) * strength).clamp(Vec3::ZERO, Vec3::splat(1e12));
    let metallic = pbr.metallic_factor();
    let roughness = pbr.roughness_factor().clamp(0.0, 1.0);
    let transmission = m.transmission().map_or(0.0, |t| t.transmission_factor());

    let mut material = Material {
        emission,
        two_sided: m.double_sided(),
        ..Material::plain(name.clone(), MaterialKind::Diffuse, base)
    };
    let mut mapping;
    if transmission > 0.5 {
        material.kind = MaterialKind::Dielectric;
        material.ior = m.ior().filter(|i| *i >= 1.0).unwrap_or(1.5);
        mapping = format!(
            "dielectric (transmissionFactor {transmission} > 0.5), albedo {} from baseColorFactor, ior {}{}",
            vec_text(base),
            material.ior,
            if m.ior().is_some() { " from KHR_materials_ior" } else { " (default)" }
        );
        if transmission < 1.0 {
            ignored.add("partial transmission (rendered as full)", who.clone());
        }
    } else if metallic >= 0.5 {
        if roughness < SPECULAR_BELOW_ROUGHNESS {
            material.kind = MaterialKind::Specular;
            mapping = format!(
                "specular mirror (metallicFactor {metallic} >= 0.5, roughnessFactor {roughness} < {SPECULAR_BELOW_ROUGHNESS}), albedo {} from baseColorFactor",
                vec_text(base)
            );
        } else {
            material.kind = MaterialKind::Glossy;
            material.roughness = roughness;
            mapping = format!(
                "glossy (metallicFactor {metallic} >= 0.5), albedo {} from baseColorFactor, roughness {roughness} from roughnessFactor",
                vec_text(base)
            );
        }
        if metallic < 1.0 {
            ignored.add("the diffuse part of partly metallic materials", who.clone());
        }
    } else {
        mapping = format!("diffuse (metallicFactor {metallic} < 0.5), albedo {} from baseColorFactor", vec_text(base));
        if metallic > 0.0 {
            ignored.add("the metal part of partly metallic materials", who.clone());
        }
        if transmission > 0.0 {
            ignored.add("transmission of 0.5 or less", who.clone());
        }
    }
    if emission.max_element() > 0.0 {
        mapping += &format!(
            ", emission {} from emissiveFactor{}",
            vec_text(emission),
            if m.emissive_strength().is_some() { " x KHR_materials_emissive_strength" } else { "" }
        );
        if m.double_sided() {
            mapping += " (two-sided: doubleSided)";
        }
    }
    // The image of a texture slot, where it is a file or embedded and reads TEXCOORD_0; else noted.
    let mut image = |slot: &str, info: Option<gltf::texture::Info<'_>>, usage: TextureUse| -> Option<TextureRef> {
        let info = info?;
        let place = format!("{slot} of {who}");
        if info.tex_coord() != 0 {
            ignored.add("textures of texture coordinates other than TEXCOORD_0", place);
            return None;
        }
        let texture = info.texture();
        let sampler = texture.sampler();
        if sampler.wrap_s() != gltf::texture::WrappingMode::Repeat
            || sampler.wrap_t() != gltf::texture::WrappingMode::Repeat
        {
            ignored.add("texture wrap modes other than REPEAT (read as REPEAT)", place.clone());
        }
        let image = texture.source();
        if let Some(bytes) = embedded.get(&image.index()) {
            match bytes {
                Ok(bytes) => return Some(TextureRef::embedded(file, image.index(), bytes.clone(), usage)),
                Err(why) => ignored.add("textures", format!("{place} (images[{}]: {why})", image.index())),
            }
            return None;
        }
        match image.source() {
            gltf::image::Source::Uri { uri, .. } if !uri.contains("://") => {
                let origin = file.display().to_string();
                let r = TextureRef::new(&super::gltf::percent_decode(uri), dir, &origin, None, usage);
                if r.path.is_file() {
                    return Some(r);
                }
                ignored.add("textures", format!("{place} ({} does not exist)", r.shown()));
            }
            _ => ignored.add("textures of images not beside the file (uris with a scheme)", place),
        }
        None
    };
    let base_texture = image("baseColorTexture", pbr.base_color_texture(), TextureUse::Colour);
    let roughness_use = TextureUse::roughness(Channel::Green, Remap::Identity);
    let roughness_texture = image("metallicRoughnessTexture", pbr.metallic_roughness_texture(), roughness_use);
    // A slot the closure could not read is noted already; one read but not used is noted below.
    let (base_read, roughness_read) = (base_texture.is_some(), roughness_texture.is_some());
    if material.kind != MaterialKind::Dielectric {
        if let Some(t) = base_texture {
            mapping += &format!(", times baseColorTexture {}", t.path.display());
            material.albedo_texture = Some(t);
        }
    }
    if material.kind == MaterialKind::Glossy {
        if let Some(t) = roughness_texture {
            mapping += &format!(", roughness times the green of metallicRoughnessTexture {}", t.path.display());
            material.roughness_texture = Some(t);
        }
    }
    let textures: Vec<&str> = [
        ("baseColorTexture", base_read && material.albedo_texture.is_none()),
        ("metallicRoughnessTexture", roughness_read && material.roughness_texture.is_none()),
        ("normalTexture", m.normal_texture().is_some()),
        ("occlusionTexture", m.occlusion_texture().is_some()),
        ("emissiveTexture", m.emissive_texture().is_some()),
        ("transmissionTexture", m.transmission().is_some_and(|t| t.transmission_texture().is_some())),
    ]
    .into_iter()
    .filter_map(|(n, present)| present.then_some(n))
    .collect();
    if !textures.is_empty() {
        ignored.add("textures", format!("{} of {who}", textures.join(", ")));
    }
    match m.alpha_mode() {
        gltf::material::AlphaMode::Opaque => {}
        mode => ignored.add("alpha", format!("alphaMode {mode:?} of {who}")),
    }
    if let Some(others) = m.extensions() {
        for key in others.keys() {
            ignored.add("material extensions", format!("{key} of {who}"));
        }
    }
    FileMaterial { name, material, mapping: format!("glTF {who}: {mapping}") }
}
