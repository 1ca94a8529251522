//! pbrt's `mix` material (pbrt-v4's `materials` and `amount`, pbrt-v3's
//! `namedmaterial1`, `namedmaterial2`) mapped onto rlpt's mix, one of the two
//! per hit (`docs/pbrt.md`).

use glam::Vec3;

use super::lexer::Loc;
use super::material::{FloatImage, Mapped, Reader};
use super::params::Params;
use super::Importer;
use crate::scene::procedural::{Combine, Operand, Procedural};
use crate::scene::texture::Factor;
use crate::scene::{Material, MaterialKind, SceneError, TextureRef, TextureUse};
use crate::shared;

impl Importer {
    /// `mix` (pbrt-v4's `materials` and `amount`, the chance of the second;
    /// pbrt-v3's `namedmaterial1` and `namedmaterial2`, `amount` the first's
    /// weight): rlpt's mix, one of the two per hit. Two diffuse materials without
    /// procedural textures blend their albedos instead (per hit where textured),
    /// which is the same in expectation and cheaper; an amount of 0 or 1 is the
    /// one material it picks.
    pub(super) fn mix(&mut self, p: &Params, loc: &Loc, label: &str) -> Result<Mapped, SceneError> {
        let what = format!("material \"{label}\" (mix)");
        let v3 = p.get("materials", &["string"]).is_none()
            && (p.get("namedmaterial1", &["string"]).is_some() || p.get("namedmaterial2", &["string"]).is_some());
        let names = if v3 {
            // pbrt-v3 weighs namedmaterial1 by amount: it is rlpt's second.
            let name = |n: &str| -> Result<String, SceneError> {
                p.string(n)?.ok_or_else(|| loc.error(format!("{what}: missing \"string {n}\"")))
            };
            vec![name("namedmaterial2")?, name("namedmaterial1")?]
        } else {
            let names = p.get("materials", &["string"]).map(|q| q.strings()).transpose()?;
            names
                .filter(|n| n.len() == 2)
                .ok_or_else(|| loc.error(format!("{what}: expected \"string materials\" with two material names")))?
        };
        let mut pair = [0usize; 2];
        for (slot, n) in pair.iter_mut().zip(&names) {
            *slot = *self
                .named_materials
                .get(n)
                .ok_or_else(|| loc.error(format!("{what}: \"{n}\" is not a named material made before it")))?;
        }
        let depth = 1 + mix_depth(&self.materials, pair[0]).max(mix_depth(&self.materials, pair[1]));
        if depth > shared::MIX_MAX_DEPTH {
            return Err(loc.error(format!(
                "{what}: mixes nest at most {} levels deep; this one would be {depth}",
                shared::MIX_MAX_DEPTH
            )));
        }
        let amount = {
            let mut r = self.reader(p, loc, what.clone());
            mix_amount(&mut r, v3)?
        };
        let (a, b) = (&self.materials[pair[0]].material, &self.materials[pair[1]].material);
        let t = amount.value;
        let blendable = |m: &Material| {
            m.kind == MaterialKind::Diffuse && m.albedo_procedural.is_none() && m.roughness_texture.is_none()
        };
        let by = amount.describe();
        let (material, how) = if amount.image.is_none() && amount.procedural.is_none() && (t == 0.0 || t == 1.0) {
            let (pick, name) = if t == 0.0 { (a, &names[0]) } else { (b, &names[1]) };
            (pick.clone(), format!("\"{name}\" alone ({by})"))
        } else if blendable(a) && blendable(b) && amount.procedural.is_none() {
            if a.albedo_texture.is_none() && b.albedo_texture.is_none() && amount.image.is_none() {
                let mut m = a.clone();
                m.albedo = a.albedo.lerp(b.albedo, t);
                (m, format!("albedos of \"{}\" and \"{}\" blended ({by})", names[0], names[1]))
            } else {
                // Textured: the two blended per hit as a procedural mix.
                let op = |m: &Material| Operand { value: m.albedo, image: m.albedo_texture.clone() };
                let amount_op = Operand { value: Vec3::splat(t), image: amount.image.clone() };
                let mut m = a.clone();
                let p = Procedural { combine: Combine::Mix, a: op(a), b: op(b), amount: amount_op };
                (m.albedo, m.albedo_texture, m.albedo_procedural) = (Vec3::ONE, None, Some(p));
                (m, format!("albedos of \"{}\" and \"{}\" blended per hit ({by})", names[0], names[1]))
            }
        } else {
            let mut m = Material::mix(label, pair[0] as u32, pair[1] as u32, t);
            (m.albedo_texture, m.albedo_procedural) = (amount.image, amount.procedural);
            (m, format!("\"{}\" or \"{}\", chosen per hit ({by})", names[0], names[1]))
        };
        let kind = format!("{:?}", material.kind).to_lowercase();
        Ok(Mapped { material, mapping: format!("mix -> {kind} ({how})") })
    }
}

/// How many levels of mixes importer material `m` is (0: not a mix). Bounded:
/// each mix names materials made before it, and is refused past `MIX_MAX_DEPTH`.
fn mix_depth(materials: &[Mapped], m: usize) -> u32 {
    match materials[m].material.mix {
        None => 0,
        Some([a, b]) => 1 + mix_depth(materials, a as usize).max(mix_depth(materials, b as usize)),
    }
}

/// A mix's amount: the chance of its second material, `value` times the image
/// or procedural texture's red at a hit where there is one.
struct Amount {
    value: f32,
    image: Option<TextureRef>,
    procedural: Option<Procedural>,
}

impl Amount {
    fn describe(&self) -> String {
        match (&self.image, &self.procedural) {
            (Some(t), _) if self.value == 1.0 => format!("amount texture {}", t.path.display()),
            (Some(t), _) => format!("amount {} times texture {}", self.value, t.path.display()),
            (None, Some(p)) => format!("amount the {}", p.describe()),
            (None, None) => format!("amount {}", self.value),
        }
    }
}

/// A mix's `amount` (default 0.5): a number from 0 to 1; a float `imagemap`
/// (read grey per hit) or a procedural texture, read per hit; a colour image
/// read by its red channel (noted); another texture's mean (noted). pbrt-v3's
/// spectrum amount weighs `namedmaterial1`, a colour of unequal channels taken
/// as their mean (noted).
fn mix_amount(r: &mut Reader<'_>, v3: bool) -> Result<Amount, SceneError> {
    let constant = |value| Amount { value, image: None, procedural: None };
    let amount = match r.params.get("amount", &["texture"]).cloned() {
        Some(q) => {
            let tex = q.string()?;
            let Some(t) = r.textures.get(&tex).cloned() else {
                return Err(q
                    .loc
                    .error(format!("parameter {} names texture \"{tex}\", which is not defined", q.label())));
            };
            if let Some(FloatImage { image, srgb, scale, invert }) = t.float_image {
                let usage = TextureUse::Float { srgb, scale: Factor(scale), invert };
                Amount { value: 1.0, image: Some(TextureRef { usage, ..image }), procedural: None }
            } else if let Some(procedural) = t.procedural {
                Amount { value: 1.0, image: None, procedural: Some(procedural) }
            } else if let Some(image) = t.image {
                if t.scale.x != t.scale.y || t.scale.x != t.scale.z {
                    r.note(format!("{}: a colour scale {} read by its red", q.label(), text(t.scale)))?;
                }
                r.note(format!("{} is the colour texture \"{tex}\", read by its red channel", q.label()))?;
                Amount { value: t.scale.x, image: Some(image), procedural: None }
            } else {
                constant(r.scalar("amount", 0.5)? as f32)
            }
        }
        None if v3 => {
            let c = r.colour("amount", Vec3::splat(0.5))?;
            if c.x != c.y || c.x != c.z {
                r.note(format!("amount {}: one chance per hit, the mean of its channels", text(c)))?;
            }
            constant((c.x + c.y + c.z) / 3.0)
        }
        None => constant(r.scalar("amount", 0.5)? as f32),
    };
    if !(0.0..=1.0).contains(&amount.value) {
        let at = r.params.touch("amount").map_or(r.loc.clone(), |q| q.loc.clone());
        return Err(at.error(format!("{}: amount {} must be from 0 to 1", r.what, amount.value)));
    }
    Ok(amount)
}

fn text(v: Vec3) -> String {
    format!("[{}, {}, {}]", v.x, v.y, v.z)
}
