//! `[[material]]` tables: each type's keys, their ranges, and a material's index
//! by name for the shapes that use it.

use super::*;
use crate::scene::texture::{Channel, Factor, Remap, TextureRef, TextureUse};
use crate::shared;

/// A TOML scene's roughness texture: the mean of its RGB, read as the roughness.
const ROUGHNESS_TEXELS: TextureUse = TextureUse::roughness(Channel::Average, Remap::Identity);

pub(super) const MATERIAL_TYPES: &[&str] =
    &["diffuse", "specular", "glossy", "dielectric", "conductor", "coated", "emissive", "mix"];
/// Largest accepted component of a conductor's `eta` and `k` (measured metals lie well below).
pub(super) const MAX_CONDUCTOR_INDEX: f64 = 100.0;

pub(super) fn material_keys(kind: MaterialKind) -> &'static [&'static str] {
    match kind {
        MaterialKind::Diffuse | MaterialKind::Specular => {
            &["name", "type", "albedo", "emission", "two_sided", "albedo_texture"]
        }
        MaterialKind::Glossy => {
            &["name", "type", "albedo", "roughness", "emission", "two_sided", "albedo_texture", "roughness_texture"]
        }
        MaterialKind::Coated => &[
            "name",
            "type",
            "albedo",
            "roughness",
            "ior",
            "eta",
            "k",
            "base_roughness",
            "emission",
            "two_sided",
            "albedo_texture",
            "roughness_texture",
        ],
        MaterialKind::Dielectric | MaterialKind::RoughDielectric => &[
            "name",
            "type",
            "ior",
            "albedo",
            "roughness",
            "emission",
            "two_sided",
            "albedo_texture",
            "roughness_texture",
        ],
        MaterialKind::Conductor => {
            &["name", "type", "eta", "k", "roughness", "emission", "two_sided", "albedo_texture", "roughness_texture"]
        }
        MaterialKind::Emissive => &["name", "type", "emission", "two_sided"],
        MaterialKind::Mix => &["name", "type", "materials", "amount", "amount_texture", "emission", "two_sided"],
    }
}

/// The optional texture key `key` (a file name, resolved against `base`).
fn texture_key(
    t: &Table<'_, '_, '_>,
    key: &str,
    base: &Path,
    usage: TextureUse,
) -> Result<Option<TextureRef>, SceneError> {
    let Some(v) = t.get(key) else { return Ok(None) };
    let written = t.string(key, v, "the file name of a PNG, JPEG, TGA, EXR or HDR image")?;
    if written.is_empty() {
        return Err(t.error_at(v.span(), format!("key `{key}` must name an image file, found \"\"")));
    }
    Ok(Some(TextureRef::new(written, base, t.src.file, Some(t.src.line_col(v.span().start)), usage)))
}

pub(super) fn type_name(kind: MaterialKind) -> &'static str {
    match kind {
        MaterialKind::Diffuse => "diffuse",
        MaterialKind::Specular => "specular",
        MaterialKind::Glossy => "glossy",
        MaterialKind::Dielectric | MaterialKind::RoughDielectric => "dielectric",
        MaterialKind::Conductor => "conductor",
        MaterialKind::Coated => "coated",
        MaterialKind::Emissive => "emissive",
        MaterialKind::Mix => "mix",
    }
}

/// Returns the material and the span of its name (for duplicate messages).
pub(super) fn parse_material(
    t: &Table<'_, '_, '_>,
    defined: &[Material],
    defined_lines: &[usize],
    base: &Path,
) -> Result<(Material, Range<usize>), SceneError> {
    let name_value = t.required("name", "a unique, non-empty string naming the material")?;
    let name = t.string("name", name_value, "a non-empty string")?;
    if name.is_empty() {
        return Err(t.error_at(name_value.span(), "key `name` must be a non-empty string, found \"\""));
    }
    if let Some(i) = defined.iter().position(|m| m.name == name) {
        return Err(t.error_at(
            name_value.span(),
            format!(
                "duplicate material name \"{name}\" (already defined on line {}); \
                 material names must be unique",
                defined_lines[i]
            ),
        ));
    }
    let t = Table { src: t.src, label: format!("[[material]] \"{name}\""), table: t.table, span: t.span.clone() };

    let types = MATERIAL_TYPES.join(", ");
    let type_value = t.required("type", &format!("one of {types}"))?;
    let kind = match t.string("type", type_value, &format!("one of {types}"))? {
        "diffuse" => MaterialKind::Diffuse,
        "specular" => MaterialKind::Specular,
        "glossy" => MaterialKind::Glossy,
        "dielectric" => MaterialKind::Dielectric,
        "conductor" => MaterialKind::Conductor,
        "coated" => MaterialKind::Coated,
        "emissive" => MaterialKind::Emissive,
        "mix" => MaterialKind::Mix,
        other => {
            return Err(t.error_at(type_value.span(), format!("key `type` must be one of {types}, found \"{other}\"")))
        }
    };
    let ty = type_name(kind);
    t.check_keys(material_keys(kind), &format!(" for a material of type \"{ty}\""))?;

    let albedo = |hint: &str| -> Result<Vec3, SceneError> {
        let v = t.required("albedo", hint)?;
        Ok(to_vec3(t.vec3("albedo", v, |x| (0.0..=1.0).contains(&x), "in [0, 1]")?))
    };
    let emission = match t.get("emission") {
        None => None,
        Some(v) => Some(to_vec3(t.vec3("emission", v, |x| (0.0..=MAX_RADIANCE).contains(&x), "from 0 to 1e12")?)),
    };
    let mut material = Material {
        emission: emission.unwrap_or(Vec3::ZERO),
        two_sided: match t.get("two_sided") {
            None => false,
            Some(v) => t.boolean("two_sided", v)?,
        },
        albedo_texture: texture_key(&t, "albedo_texture", base, TextureUse::Colour)?,
        roughness_texture: texture_key(&t, "roughness_texture", base, ROUGHNESS_TEXELS)?,
        ..Material::plain(name, kind, Vec3::ZERO)
    };
    // With a roughness texture, `roughness` is its factor, 1 where not given.
    let textured = material.roughness_texture.is_some();
    match kind {
        MaterialKind::Diffuse => {
            material.albedo = albedo("reflectance [r, g, b], components in [0, 1]")?;
        }
        MaterialKind::Specular => {
            material.albedo = albedo("mirror reflectance [r, g, b], components in [0, 1]")?;
        }
        MaterialKind::Glossy => {
            material.albedo = albedo("reflectance [r, g, b], components in [0, 1]")?;
            material.roughness = ggx_roughness(&t, "GGX roughness, a number in (0, 1]", textured)?;
        }
        MaterialKind::Dielectric | MaterialKind::RoughDielectric => {
            material.ior = t.ranged(
                "ior",
                t.required("ior", "index of refraction, a number >= 1")?,
                |x| x >= 1.0,
                "a number >= 1",
            )?;
            // Roughness 0 (or none) is the smooth dielectric, unchanged; above 0 the GGX one.
            if let Some(v) = t.get("roughness") {
                material.roughness =
                    t.ranged("roughness", v, |x| (0.0..=1.0).contains(&x), "a number in [0, 1] (0: smooth)")?;
                if material.roughness > 0.0 {
                    material.kind = MaterialKind::RoughDielectric;
                } else if textured {
                    return Err(t.error_here("a `roughness_texture` needs `roughness` above 0 (its factor) or none"));
                } else {
                    material.roughness = 1.0;
                }
            } else if textured {
                material.kind = MaterialKind::RoughDielectric;
            }
            material.albedo = match t.get("albedo") {
                None => Vec3::ONE,
                Some(v) => to_vec3(t.vec3("albedo", v, |x| (0.0..=1.0).contains(&x), "in [0, 1]")?),
            };
        }
        MaterialKind::Conductor => {
            material.eta = conductor_index(&t, "eta", |x| x > 0.0 && x <= MAX_CONDUCTOR_INDEX, "in (0, 100]")?;
            material.k = conductor_index(&t, "k", |x| (0.0..=MAX_CONDUCTOR_INDEX).contains(&x), "in [0, 100]")?;
            material.albedo = Vec3::ONE;
            material.roughness = match t.get("roughness") {
                None if textured => 1.0,
                None => 0.0,
                Some(v) => {
                    t.ranged("roughness", v, |x| (0.0..=1.0).contains(&x), "a number in [0, 1] (0: a mirror)")?
                }
            };
        }
        MaterialKind::Coated => {
            let conductor = t.get("eta").is_some() || t.get("k").is_some();
            material.albedo = if conductor {
                // A conductor base: its index, and an albedo that tints it (default 1).
                material.eta = conductor_index(&t, "eta", |x| x > 0.0 && x <= MAX_CONDUCTOR_INDEX, "in (0, 100]")?;
                material.k = conductor_index(&t, "k", |x| (0.0..=MAX_CONDUCTOR_INDEX).contains(&x), "in [0, 100]")?;
                material.base_roughness = Some(match t.get("base_roughness") {
                    None if textured => 1.0,
                    None => return Err(t.error_here("missing key `base_roughness` (the conductor base's GGX roughness, a number in (0, 1]; required with `eta` and `k`)")),
                    Some(v) => t.ranged("base_roughness", v, |x| x > 0.0 && x <= 1.0, "a number in (0, 1] (0 < base_roughness <= 1)")?,
                });
                match t.get("albedo") {
                    None => Vec3::ONE,
                    Some(_) => albedo("the conductor base's tint [r, g, b], components in [0, 1]")?,
                }
            } else {
                if t.get("base_roughness").is_some() {
                    return Err(t.error_here("key `base_roughness` needs a conductor base: give its `eta` and `k` too"));
                }
                albedo("the base's reflectance [r, g, b], components in [0, 1]")?
            };
            // The coat's roughness; 0 a smooth coat. With a conductor base a roughness
            // texture scales the base's roughness, and the coat's is required.
            material.roughness = match t.get("roughness") {
                None if textured && !conductor => 1.0,
                None => {
                    return Err(t.error_here(
                        "missing key `roughness` (the coat's GGX roughness, a number in [0, 1]; 0 a smooth coat)",
                    ))
                }
                Some(v) => {
                    t.ranged("roughness", v, |x| (0.0..=1.0).contains(&x), "a number in [0, 1] (0: a smooth coat)")?
                }
            };
            material.ior = match t.get("ior") {
                None => 1.5,
                Some(v) => {
                    t.ranged("ior", v, |x| (1.0..=MAX_CONDUCTOR_INDEX).contains(&x), "a number from 1 to 100")?
                }
            };
        }
        MaterialKind::Emissive => {
            if emission.is_none() {
                return Err(t.error_here("missing key `emission` (emitted radiance [r, g, b], components >= 0)"));
            }
        }
        MaterialKind::Mix => parse_mix(&t, &mut material, defined, base)?,
    }
    Ok((material, name_value.span()))
}

/// A mix's keys: `materials`, the names of two materials defined before it,
/// `amount` (default 0.5), the chance of the second at a hit, and
/// `amount_texture`, a grey image whose value at the hit multiplies it.
fn parse_mix(t: &Table<'_, '_, '_>, m: &mut Material, defined: &[Material], base: &Path) -> Result<(), SceneError> {
    let expected = "an array of the names of two materials defined before this one";
    let v = t.required("materials", expected)?;
    let DeValue::Array(items) = v.get_ref() else {
        return Err(t.error_at(v.span(), format!("key `materials` must be {expected}, found {}", t.src.describe(v))));
    };
    if items.len() != 2 {
        return Err(t.error_at(v.span(), format!("key `materials` must be {expected}, found {} names", items.len())));
    }
    let mut pair = [0u32; 2];
    for (slot, item) in pair.iter_mut().zip(items.iter()) {
        let name = t.string("materials", item, expected)?;
        let Some(i) = defined.iter().position(|d| d.name == name) else {
            let names: Vec<&str> = defined.iter().map(|d| d.name.as_str()).collect();
            return Err(t.error_at(
                item.span(),
                format!(
                    "key `materials` names \"{name}\", which is not a material defined before this one (defined: {})",
                    names.join(", ")
                ),
            ));
        };
        if defined[i].emits() {
            return Err(t.error_at(
                item.span(),
                format!("material \"{name}\" emits light; a mix's materials may not (give the mix its `emission`)"),
            ));
        }
        *slot = i as u32;
    }
    let amount = match t.get("amount") {
        None => 0.5,
        Some(a) => t.ranged("amount", a, |x| (0.0..=1.0).contains(&x), "a number from 0 to 1")?,
    };
    let usage = TextureUse::Float { srgb: false, scale: Factor(1.0), invert: false };
    let texture = texture_key(t, "amount_texture", base, usage)?;
    let mut all = defined.to_vec();
    all.push(Material { albedo_texture: texture, ..Material::mix(m.name.clone(), pair[0], pair[1], amount) });
    if crate::scene::mix_depth(&all, defined.len() as u32).is_none() {
        return Err(t.error_at(
            v.span(),
            format!("mixes nest at most {} levels deep; this one would be deeper", shared::MIX_MAX_DEPTH),
        ));
    }
    let mixed = all.pop().expect("pushed above");
    (m.kind, m.albedo, m.mix, m.albedo_texture) = (mixed.kind, mixed.albedo, mixed.mix, mixed.albedo_texture);
    Ok(())
}

pub(super) fn material_index(t: &Table<'_, '_, '_>, materials: &[Material]) -> Result<u32, SceneError> {
    let v = t.required("material", "the name of a [[material]]")?;
    let name = t.string("material", v, "the name of a [[material]]")?;
    match materials.iter().position(|m| m.name == name) {
        Some(i) => Ok(i as u32),
        None => {
            let names: Vec<&str> = materials.iter().map(|m| m.name.as_str()).collect();
            Err(t.error_at(v.span(), format!("material \"{name}\" is not defined (defined: {})", names.join(", "))))
        }
    }
}

/// The required `roughness` key of a GGX lobe, in (0, 1]; `expected` says what a
/// missing key should have been.
/// With a roughness texture the key is its factor, 1 where absent.
/// A conductor's `eta` or `k` (required), per channel.
fn conductor_index(t: &Table<'_, '_, '_>, key: &str, ok: fn(f64) -> bool, expected: &str) -> Result<Vec3, SceneError> {
    let hint = format!("[r, g, b], components {expected}");
    Ok(to_vec3(t.vec3(key, t.required(key, &hint)?, ok, expected)?))
}

fn ggx_roughness(t: &Table<'_, '_, '_>, expected: &str, textured: bool) -> Result<f32, SceneError> {
    if textured && t.get("roughness").is_none() {
        return Ok(1.0);
    }
    t.ranged(
        "roughness",
        t.required("roughness", expected)?,
        |x| x > 0.0 && x <= 1.0,
        "a number in (0, 1] (0 < roughness <= 1)",
    )
}
